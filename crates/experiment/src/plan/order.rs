//! Counterbalancing the conditions across participants: the plan's `condition_order`, read
//! into one order of the conditions per row, and the row a participant runs.
//!
//! - `"mixed"` (the default): every block mixes all its cells, conditions too.
//! - `"latin-square"`: a balanced Latin square (Williams, 1949) of the conditions: each
//!   block runs the conditions one after another, in the order of the participant's row.
//!   Over the rows, each condition comes once in each position, and each condition follows
//!   each other equally often (once with an even number of conditions; with an odd number the
//!   square's rows are followed by their reverses, 2n rows, and each pair comes twice).
//! - a table, `[["friction", "frictionless"], ["frictionless", "friction"]]`: the rows
//!   written out, each an order of all the conditions' names.
//!
//! Participant `P07` (the number its ID ends in) runs row (7 − 1) mod rows, so `P01` runs
//! the first row; an ID that ends in no number is refused for a counterbalanced plan.

use serde_json::Value;

use super::error::{PlanError, invalid};
use super::spec::{ConditionSpec, Design};

/// The orders of the conditions a counterbalanced plan assigns, one per row; each row is a
/// permutation of the conditions' indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConditionOrders {
    rows: Vec<Vec<usize>>,
}

impl ConditionOrders {
    /// The balanced Latin square of `n` conditions: row `r` is the first row
    /// `0, 1, n−1, 2, n−2, …` plus `r` (mod n), for `r` in `0..n`; for odd `n` the reversed
    /// rows follow.
    pub fn williams(n: usize) -> Self {
        let mut first = Vec::with_capacity(n);
        let (mut low, mut high) = (0, n);
        for j in 0..n {
            // 0, then 1, n−1, 2, n−2, …: up from the bottom at odd places, down from the top
            // at even ones.
            if j % 2 == 1 || j == 0 {
                first.push(low);
                low += 1;
            } else {
                high -= 1;
                first.push(high);
            }
        }
        let mut rows: Vec<Vec<usize>> = (0..n)
            .map(|r| first.iter().map(|&c| (c + r) % n).collect())
            .collect();
        if n % 2 == 1 {
            let reversed: Vec<Vec<usize>> = rows
                .iter()
                .map(|row| row.iter().rev().copied().collect())
                .collect();
            rows.extend(reversed);
        }
        ConditionOrders { rows }
    }

    /// The rows.
    pub fn rows(&self) -> &[Vec<usize>] {
        &self.rows
    }

    /// The row `participant` runs: the number its ID ends in, from 1, modulo the rows.
    pub fn row_for(&self, participant: &str) -> Result<&[usize], PlanError> {
        let digits = participant.len()
            - participant
                .bytes()
                .rev()
                .take_while(u8::is_ascii_digit)
                .count();
        let tail = &participant[digits..];
        if tail.is_empty() {
            return Err(invalid(
                "condition_order",
                format!(
                    "counterbalanced by participant number, and the ID {participant:?} ends in \
                     no number (give IDs such as P01, P02, …)"
                ),
            ));
        }
        let rows = self.rows.len();
        // Modulo digit by digit: an ID may end in more digits than a u64 holds.
        let number = tail
            .bytes()
            .fold(0usize, |acc, d| (acc * 10 + usize::from(d - b'0')) % rows);
        Ok(&self.rows[(number + rows - 1) % rows])
    }

    /// Reads the plan's `condition_order` (`None`: absent) against its conditions: `None`
    /// for mixed blocks, else the rows.
    pub(super) fn read(
        value: Option<&Value>,
        conditions: &[ConditionSpec],
        design: Design,
    ) -> Result<Option<Self>, PlanError> {
        const FIELD: &str = "condition_order";
        let orders = match value {
            None => return Ok(None),
            Some(Value::String(s)) if s == "mixed" => return Ok(None),
            Some(Value::String(s)) if s == "latin-square" => Self::williams(conditions.len()),
            Some(Value::Array(rows)) => {
                if rows.is_empty() {
                    return Err(invalid(FIELD, "an empty table; give at least one order"));
                }
                let mut read = Vec::with_capacity(rows.len());
                for (r, row) in rows.iter().enumerate() {
                    read.push(read_row(row, conditions, &format!("{FIELD}[{r}]"))?);
                }
                ConditionOrders { rows: read }
            }
            Some(other) => {
                return Err(invalid(
                    FIELD,
                    format!(
                        "{other} is not \"mixed\", \"latin-square\" or a table of orders of the \
                         conditions' names"
                    ),
                ));
            }
        };
        if design == Design::TwoAfcStaircase {
            return Err(invalid(
                FIELD,
                "a 2afc-staircase plan chooses its trials online, in no blocks: leave it out",
            ));
        }
        Ok(Some(orders))
    }
}

/// One row of a written table: every condition's name once.
fn read_row(row: &Value, conditions: &[ConditionSpec], at: &str) -> Result<Vec<usize>, PlanError> {
    let Value::Array(names) = row else {
        return Err(invalid(
            at,
            format!("{row} is not a list of conditions' names"),
        ));
    };
    let mut order = Vec::with_capacity(names.len());
    for (k, name) in names.iter().enumerate() {
        let index = name
            .as_str()
            .and_then(|n| conditions.iter().position(|c| c.name == n))
            .ok_or_else(|| {
                invalid(
                    format!("{at}[{k}]"),
                    format!("{name} is not the name of a condition"),
                )
            })?;
        if order.contains(&index) {
            return Err(invalid(format!("{at}[{k}]"), format!("{name} comes twice")));
        }
        order.push(index);
    }
    if order.len() != conditions.len() {
        return Err(invalid(
            at,
            format!(
                "names {} of the {} conditions; each order runs them all",
                order.len(),
                conditions.len()
            ),
        ));
    }
    Ok(order)
}
