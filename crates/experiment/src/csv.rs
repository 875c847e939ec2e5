//! The CSV of `trials.csv` (RFC 4180), read by the analysis and by a session that resumes,
//! and the quoting its writer uses.

/// Quotes a field when it needs it (RFC 4180).
pub fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// One record: its first line and its fields.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    /// The line it starts on (from 1).
    pub line: usize,
    /// Its fields, unquoted.
    pub fields: Vec<String>,
}

/// Text that is not RFC-4180 CSV: where and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CsvError {
    /// The line (from 1).
    pub line: usize,
    /// The column (from 1).
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

/// Splits RFC-4180 text into records; a quoted field may hold commas, `""` and line breaks.
/// Line ends are `\n` or `\r\n`. Blank lines are skipped.
pub fn records(text: &str) -> Result<Vec<Record>, CsvError> {
    let mut records = Vec::new();
    let mut fields: Vec<String> = Vec::new();
    let mut field = String::new();
    let mut line = 1;
    let mut start_line = 1;
    let mut in_quotes = false;
    // Whether the current field was quoted (then only a separator may follow its closing quote).
    let mut quoted = false;
    let mut after_quote = false;
    let mut chars = text.chars().peekable();
    let error = |line: usize, column: usize, message: String| CsvError {
        line,
        column,
        message,
    };
    let mut end_record = |fields: &mut Vec<String>, field: &mut String, start_line: usize| {
        fields.push(std::mem::take(field));
        let done = std::mem::take(fields);
        if !(done.len() == 1 && done[0].is_empty()) {
            records.push(Record {
                line: start_line,
                fields: done,
            });
        }
    };
    while let Some(c) = chars.next() {
        if in_quotes {
            match c {
                '"' if chars.peek() == Some(&'"') => {
                    chars.next();
                    field.push('"');
                }
                '"' => {
                    in_quotes = false;
                    after_quote = true;
                }
                '\n' => {
                    line += 1;
                    field.push('\n');
                }
                _ => field.push(c),
            }
            continue;
        }
        match c {
            ',' => {
                fields.push(std::mem::take(&mut field));
                quoted = false;
                after_quote = false;
            }
            '\r' if chars.peek() == Some(&'\n') => {}
            '\n' => {
                end_record(&mut fields, &mut field, start_line);
                line += 1;
                start_line = line;
                quoted = false;
                after_quote = false;
            }
            '"' if field.is_empty() && !quoted => {
                in_quotes = true;
                quoted = true;
            }
            _ if after_quote => {
                return Err(error(
                    line,
                    fields.len() + 1,
                    format!("{c:?} after a closing quote (a quoted field ends at a comma)"),
                ));
            }
            '"' => {
                return Err(error(
                    line,
                    fields.len() + 1,
                    "a quote inside an unquoted field (quote the whole field, double the quote)"
                        .to_owned(),
                ));
            }
            _ => field.push(c),
        }
    }
    if in_quotes {
        return Err(error(
            start_line,
            fields.len() + 1,
            "a quoted field is not closed before the end of the file".to_owned(),
        ));
    }
    if !fields.is_empty() || !field.is_empty() {
        end_record(&mut fields, &mut field, start_line);
    }
    Ok(records)
}
