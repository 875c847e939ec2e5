//! A run's `trials.csv` read back: the CSV, each row checked against the plan (its columns,
//! its values, the design it names), errors naming the file, the row and the column.

use super::*;

// ---------------------------------------------------------------------------------------
// CSV

/// [`crate::csv::records`] of `trials.csv`, its errors naming the file and the column.
pub(super) fn parse_csv(text: &str, path: &Path) -> Result<Vec<Record>, AnalyzeError> {
    crate::csv::records(text).map_err(|e| AnalyzeError::Csv {
        path: path.to_owned(),
        line: e.line,
        column: Some(e.column),
        field: TRIALS_COLUMNS.get(e.column - 1).map(|s| (*s).to_owned()),
        message: e.message,
    })
}

// ---------------------------------------------------------------------------------------
// Rows

/// A checked row of `trials.csv`.
#[derive(Debug, Clone)]
pub(super) struct Row {
    pub(super) line: usize,
    pub(super) participant: String,
    pub(super) session: u64,
    pub(super) trial: u64,
    pub(super) practice: bool,
    pub(super) stimulus: usize,
    pub(super) condition: usize,
    /// Index of the plan's staircase (2AFC staircases).
    pub(super) staircase: Option<usize>,
    /// Identification: the stimulus answered.
    pub(super) answered: Option<usize>,
    /// 2AFC: the comparison's level.
    pub(super) level: Option<f64>,
    pub(super) correct: bool,
}

struct RowReader<'a> {
    path: &'a Path,
    line: usize,
    fields: &'a [String],
}

impl RowReader<'_> {
    fn error(&self, column: usize, message: impl Into<String>) -> AnalyzeError {
        AnalyzeError::Csv {
            path: self.path.to_owned(),
            line: self.line,
            column: Some(column + 1),
            field: Some(TRIALS_COLUMNS[column].to_owned()),
            message: message.into(),
        }
    }

    fn text(&self, column: usize) -> &str {
        &self.fields[column]
    }

    fn unsigned(&self, column: usize) -> Result<u64, AnalyzeError> {
        let t = self.text(column);
        t.trim()
            .parse::<u64>()
            .map_err(|_| self.error(column, format!("{t:?} is not a whole number ≥ 0")))
    }

    fn flag(&self, column: usize) -> Result<bool, AnalyzeError> {
        match self.text(column).trim() {
            "0" => Ok(false),
            "1" => Ok(true),
            t => Err(self.error(column, format!("{t:?} is neither 0 nor 1"))),
        }
    }

    fn number(&self, column: usize) -> Result<f64, AnalyzeError> {
        let t = self.text(column);
        match t.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.error(column, format!("{t:?} is not a finite number"))),
        }
    }

    fn interval(&self, column: usize) -> Result<u8, AnalyzeError> {
        match self.text(column).trim() {
            "1" => Ok(1),
            "2" => Ok(2),
            t => Err(self.error(column, format!("{t:?} is neither interval 1 nor 2"))),
        }
    }

    fn empty(&self, column: usize, design: Design) -> Result<(), AnalyzeError> {
        let t = self.text(column);
        if t.trim().is_empty() {
            Ok(())
        } else {
            Err(self.error(
                column,
                format!("{t:?}: must be empty in a {} design", design.name()),
            ))
        }
    }

    fn name_in(&self, column: usize, names: &[&str], what: &str) -> Result<usize, AnalyzeError> {
        let t = self.text(column);
        names.iter().position(|n| *n == t).ok_or_else(|| {
            self.error(
                column,
                format!(
                    "{t:?} is not a {what} of the plan (they are {})",
                    names
                        .iter()
                        .map(|n| format!("{n:?}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
    }
}

const C_PARTICIPANT: usize = 0;
const C_SESSION: usize = 1;
const C_BLOCK: usize = 2;
const C_TRIAL: usize = 3;
const C_PRACTICE: usize = 4;
const C_DESIGN: usize = 5;
const C_STIMULUS: usize = 6;
const C_CONDITION: usize = 7;
const C_STAIRCASE: usize = 8;
pub(super) const C_LEVEL: usize = 9;
const C_REFERENCE: usize = 10;
const C_INTERVAL: usize = 11;
const C_RESPONSE: usize = 12;
const C_CORRECT: usize = 13;

/// Reads and checks `trials.csv` against the plan.
pub(super) fn read_trials(path: &Path, plan: &Plan) -> Result<Vec<Row>, AnalyzeError> {
    let text = std::fs::read_to_string(path).map_err(|error| AnalyzeError::Read {
        path: path.to_owned(),
        error,
    })?;
    let records = parse_csv(&text, path)?;
    let csv_error = |line: usize, column: Option<usize>, message: String| AnalyzeError::Csv {
        path: path.to_owned(),
        line,
        column,
        field: column.and_then(|c| TRIALS_COLUMNS.get(c - 1).map(|s| (*s).to_owned())),
        message,
    };
    let Some((header, rows)) = records.split_first() else {
        return Err(csv_error(
            1,
            None,
            format!(
                "the file is empty; it needs the header {}",
                TRIALS_COLUMNS.join(",")
            ),
        ));
    };
    for (i, expected) in TRIALS_COLUMNS.iter().enumerate() {
        let found = header.fields.get(i).map(String::as_str);
        if found != Some(*expected) {
            return Err(AnalyzeError::Csv {
                path: path.to_owned(),
                line: header.line,
                column: Some(i + 1),
                field: None,
                message: format!(
                    "the header has {}, expected {expected:?}; the header must be {}",
                    match found {
                        Some(f) => format!("{f:?}"),
                        None => "nothing".to_owned(),
                    },
                    TRIALS_COLUMNS.join(",")
                ),
            });
        }
    }
    if header.fields.len() > TRIALS_COLUMNS.len() {
        return Err(csv_error(
            header.line,
            Some(TRIALS_COLUMNS.len() + 1),
            format!(
                "the header has {} columns, expected {}: {}",
                header.fields.len(),
                TRIALS_COLUMNS.len(),
                TRIALS_COLUMNS.join(",")
            ),
        ));
    }
    let spec = plan.spec();
    let design = spec.design;
    let stimuli: Vec<&str> = spec.stimuli.iter().map(|s| s.name.as_str()).collect();
    let conditions: Vec<&str> = spec.conditions.iter().map(|c| c.name.as_str()).collect();
    let staircases: Vec<&str> = spec.staircases.iter().map(|s| s.name.as_str()).collect();
    let reference = spec.reference.as_ref().map(|r| r.value);
    let mut seen: HashMap<u64, usize> = HashMap::new();
    let mut out = Vec::with_capacity(rows.len());
    for record in rows {
        if record.fields.len() != TRIALS_COLUMNS.len() {
            return Err(csv_error(
                record.line,
                None,
                format!(
                    "{} fields, the header has {}",
                    record.fields.len(),
                    TRIALS_COLUMNS.len()
                ),
            ));
        }
        let r = RowReader {
            path,
            line: record.line,
            fields: &record.fields,
        };
        let session = r.unsigned(C_SESSION)?;
        let block = r.unsigned(C_BLOCK)?;
        let trial = r.unsigned(C_TRIAL)?;
        let practice = r.flag(C_PRACTICE)?;
        if practice && block != 0 {
            return Err(r.error(C_BLOCK, format!("{block}: a practice trial is in block 0")));
        }
        if let Some(first) = seen.insert(trial, record.line) {
            return Err(r.error(
                C_TRIAL,
                format!("trial {trial} appears again (first on line {first}); a trial number may appear once only"),
            ));
        }
        if r.text(C_DESIGN) != design.name() {
            return Err(r.error(
                C_DESIGN,
                format!(
                    "{:?} does not match the plan's design {:?}",
                    r.text(C_DESIGN),
                    design.name()
                ),
            ));
        }
        let stimulus = r.name_in(C_STIMULUS, &stimuli, "stimulus")?;
        let condition = r.name_in(C_CONDITION, &conditions, "condition")?;
        let correct = r.flag(C_CORRECT)?;
        let mut row = Row {
            line: record.line,
            participant: r.text(C_PARTICIPANT).to_owned(),
            session,
            trial,
            practice,
            stimulus,
            condition,
            staircase: None,
            answered: None,
            level: None,
            correct,
        };
        match (design, reference) {
            (Design::Identification, _) => {
                for c in [C_STAIRCASE, C_LEVEL, C_REFERENCE, C_INTERVAL] {
                    r.empty(c, design)?;
                }
                let answered = r.name_in(C_RESPONSE, &stimuli, "stimulus")?;
                if correct != (answered == stimulus) {
                    return Err(r.error(
                        C_CORRECT,
                        format!(
                            "{} but the response {:?} {} the stimulus {:?}",
                            u8::from(correct),
                            stimuli[answered],
                            if answered == stimulus { "is" } else { "is not" },
                            stimuli[stimulus]
                        ),
                    ));
                }
                row.answered = Some(answered);
            }
            (_, Some(reference)) => {
                if design == Design::TwoAfcStaircase {
                    // Practice trials run before the staircases, at the first one's start.
                    if !(practice && r.text(C_STAIRCASE).is_empty()) {
                        row.staircase = Some(r.name_in(C_STAIRCASE, &staircases, "staircase")?);
                    }
                } else {
                    r.empty(C_STAIRCASE, design)?;
                }
                let level = r.number(C_LEVEL)?;
                if level <= 0.0 {
                    return Err(r.error(
                        C_LEVEL,
                        format!("{level} is not positive: levels are folded about the reference multiplicatively"),
                    ));
                }
                let given = r.number(C_REFERENCE)?;
                if (given - reference).abs() > 1e-9 * reference.abs() {
                    return Err(r.error(
                        C_REFERENCE,
                        format!("{given} is not the plan's reference value {reference}"),
                    ));
                }
                let comparison = r.interval(C_INTERVAL)?;
                let response = r.interval(C_RESPONSE)?;
                let chose_comparison = response == comparison;
                // Above the reference the comparison is the right answer, below it the
                // reference; at the reference neither, and either answer may be scored.
                let expected = if level > reference {
                    Some(chose_comparison)
                } else if level < reference {
                    Some(!chose_comparison)
                } else {
                    None
                };
                if let Some(e) = expected
                    && e != correct
                {
                    return Err(r.error(
                        C_CORRECT,
                        format!(
                            "{} but the response (interval {response}) chose the {} at level {level} {} the reference {reference}",
                            u8::from(correct),
                            if chose_comparison { "comparison" } else { "reference" },
                            if level > reference { "above" } else { "below" },
                        ),
                    ));
                }
                row.level = Some(level);
            }
            (_, None) => {
                return Err(AnalyzeError::Options(format!(
                    "the plan's design is {} but it has no reference",
                    design.name()
                )));
            }
        }
        out.push(row);
    }
    Ok(out)
}
