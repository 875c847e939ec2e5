//! The `eval` command: evaluate one patch at parameters read line by line, write one JSON
//! object per line.
//!
//! Input: one query per line, `u` for a curve, `u v` for a surface, separated by whitespace;
//! blank lines and lines starting with `#` are skipped. Output, one line per query, flushed
//! at once so the command can be driven interactively or through a pipe:
//!
//! - curve: `{"u", "p", "du", "duu", "tangent", "normal", "curvature"}`
//! - surface: `{"u", "v", "p", "du", "dv", "duu", "duv", "dvv", "normal"}`
//!
//! The first bad line stops the run with an [`EvalError`] naming the line; the lines before it
//! have been answered.

use std::io::{self, BufRead, Write};

use nurbs::{Curve, Point, Surface};
use serde::Serialize;

use scene::Patch;

/// A curve evaluated at `u` (see [`nurbs::Curve::frame`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CurveSample {
    /// The parameter.
    pub u: f32,
    /// `C(u)`.
    pub p: Vec<f32>,
    /// `C'(u)`.
    pub du: Vec<f32>,
    /// `C''(u)`.
    pub duu: Vec<f32>,
    /// Unit tangent.
    pub tangent: Vec<f32>,
    /// Unit normal (planar: tangent turned clockwise; spatial: principal normal).
    pub normal: Vec<f32>,
    /// Curvature, 1/m (signed for planar curves, positive turning counter-clockwise).
    pub curvature: f32,
}

/// A surface evaluated at `(u, v)` (see [`nurbs::Surface::derivs`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SurfaceSample {
    /// First parameter.
    pub u: f32,
    /// Second parameter.
    pub v: f32,
    /// `S(u, v)`.
    pub p: [f32; 3],
    /// `∂S/∂u`.
    pub du: [f32; 3],
    /// `∂S/∂v`.
    pub dv: [f32; 3],
    /// `∂²S/∂u²`.
    pub duu: [f32; 3],
    /// `∂²S/∂u∂v`.
    pub duv: [f32; 3],
    /// `∂²S/∂v²`.
    pub dvv: [f32; 3],
    /// Unit normal `S_u × S_v / |S_u × S_v|` (finite limit at degenerate points).
    pub normal: [f32; 3],
}

/// An answer whose numbers can be checked before it is written.
pub(crate) trait Finite {
    /// `(field, values)` of every number of the answer.
    fn fields(&self) -> Vec<(&'static str, &[f32])>;

    /// The first field with a NaN or infinite value, as a line problem.
    fn check_finite(&self) -> Result<(), LineProblem> {
        match self
            .fields()
            .into_iter()
            .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
        {
            Some((field, _)) => Err(LineProblem::Overflow { field }),
            None => Ok(()),
        }
    }
}

impl Finite for CurveSample {
    fn fields(&self) -> Vec<(&'static str, &[f32])> {
        vec![
            ("u", core::slice::from_ref(&self.u)),
            ("p", &self.p),
            ("du", &self.du),
            ("duu", &self.duu),
            ("tangent", &self.tangent),
            ("normal", &self.normal),
            ("curvature", core::slice::from_ref(&self.curvature)),
        ]
    }
}

impl Finite for SurfaceSample {
    fn fields(&self) -> Vec<(&'static str, &[f32])> {
        vec![
            ("u", core::slice::from_ref(&self.u)),
            ("v", core::slice::from_ref(&self.v)),
            ("p", &self.p),
            ("du", &self.du),
            ("dv", &self.dv),
            ("duu", &self.duu),
            ("duv", &self.duv),
            ("dvv", &self.dvv),
            ("normal", &self.normal),
        ]
    }
}

/// Writes `answer` as one JSON line after checking that every number in it is finite.
pub(crate) fn write_answer<W: Write, T: Serialize + Finite>(
    output: &mut W,
    answer: &T,
) -> Result<(), Answer> {
    answer.check_finite()?;
    Ok(write_json(output, answer)?)
}

/// Evaluates a curve at `u` (clamped into the domain).
pub fn sample_curve<P: Point>(curve: &Curve<'_, P>, u: f32) -> CurveSample {
    let f = curve.frame(u);
    CurveSample {
        u,
        p: f.derivs.point.as_slice().to_vec(),
        du: f.derivs.du.as_slice().to_vec(),
        duu: f.derivs.duu.as_slice().to_vec(),
        tangent: f.tangent.as_slice().to_vec(),
        normal: f.normal.as_slice().to_vec(),
        curvature: f.curvature,
    }
}

/// Evaluates a surface at `(u, v)` (clamped into the domain).
pub fn sample_surface(surface: &Surface<'_>, u: f32, v: f32) -> SurfaceSample {
    let d = surface.derivs(u, v, 2);
    SurfaceSample {
        u,
        v,
        p: d.point.to_array(),
        du: d.du.to_array(),
        dv: d.dv.to_array(),
        duu: d.duu.to_array(),
        duv: d.duv.to_array(),
        dvv: d.dvv.to_array(),
        normal: surface.normal_from(u, v, &d).to_array(),
    }
}

/// Why `eval` stopped.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// A bad input line.
    #[error("line {line} ({content:?}): {problem}")]
    Line {
        /// Line number, from 1.
        line: usize,
        /// The line, trimmed.
        content: String,
        /// What is wrong with it.
        problem: LineProblem,
    },
    /// Reading the input failed.
    #[error("cannot read input: {0}")]
    Read(io::Error),
    /// Writing the output failed.
    #[error("cannot write output: {0}")]
    Write(io::Error),
    /// The object is not one the command can answer for.
    #[error("{0}")]
    Unsupported(&'static str),
}

/// What is wrong with an input line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LineProblem {
    /// Wrong number of values.
    #[error("expected {expected} value(s) `{names}`, found {found}")]
    Count {
        /// Values per line: 1 for a curve, 2 for a surface.
        expected: usize,
        /// `u` or `u v`.
        names: &'static str,
        /// Values found.
        found: usize,
    },
    /// A value is not a number.
    #[error("{name}: {text:?} is not a number")]
    NotANumber {
        /// `u` or `v`.
        name: &'static str,
        /// The text given.
        text: String,
    },
    /// A value is NaN or infinite.
    #[error("{name}: {value} is not a finite number")]
    NotFinite {
        /// `u` or `v`.
        name: &'static str,
        /// The value given.
        value: f32,
    },
    /// A finite number too large for `f32`, the type the evaluation uses.
    #[error(
        "{name}: {text} is outside the range of f32 (magnitudes up to {:e})",
        f32::MAX
    )]
    OutOfF32 {
        /// `u`, `v`, `x`, …
        name: &'static str,
        /// The text given.
        text: String,
    },
    /// A value lies outside the patch's domain.
    #[error("{name} = {value} is outside the domain [{min}, {max}]")]
    OutOfDomain {
        /// `u` or `v`.
        name: &'static str,
        /// The value given.
        value: f32,
        /// Start of the domain.
        min: f32,
        /// End of the domain.
        max: f32,
    },
    /// The answer has a value that is not finite in `f32` (validated scenes keep this from
    /// happening; the check makes sure no `null` is ever printed as an answer).
    #[error(
        "the answer's {field} is not a finite f32 here (the patch overflows f32 at this query); nothing was written"
    )]
    Overflow {
        /// The output field.
        field: &'static str,
    },
    /// The line is not UTF-8.
    #[error("not valid UTF-8")]
    NotUtf8,
}

/// Answers every query in `input` on `patch`, one JSON line each on `output` (flushed per
/// line). Returns the number of queries answered; stops at the first bad line.
pub fn run<R: BufRead, W: Write>(
    patch: &Patch,
    input: R,
    mut output: W,
) -> Result<usize, EvalError> {
    answer_lines(input, |text| match patch {
        Patch::Curve2(c) => {
            let c = c.view();
            let [u] = parse_query(text, ["u"], "u", [c.domain()])?;
            write_answer(&mut output, &sample_curve(&c, u))
        }
        Patch::Curve3(c) => {
            let c = c.view();
            let [u] = parse_query(text, ["u"], "u", [c.domain()])?;
            write_answer(&mut output, &sample_curve(&c, u))
        }
        Patch::Surface(s) => {
            let s = s.view();
            let (du, dv) = s.domain();
            let [u, v] = parse_query(text, ["u", "v"], "u v", [du, dv])?;
            write_answer(&mut output, &sample_surface(&s, u, v))
        }
    })
}

/// What answering one line can fail with: the line itself, or the output.
#[derive(Debug)]
pub(crate) enum Answer {
    /// The line is bad.
    Line(LineProblem),
    /// Writing failed.
    Output(EvalError),
}

impl From<LineProblem> for Answer {
    fn from(p: LineProblem) -> Self {
        Answer::Line(p)
    }
}

impl From<EvalError> for Answer {
    fn from(e: EvalError) -> Self {
        Answer::Output(e)
    }
}

/// Feeds every query line of `input` (trimmed; blank and `#` lines skipped) to `answer`.
/// Returns the number answered; stops at the first bad line with an error naming it.
pub(crate) fn answer_lines<R: BufRead>(
    mut input: R,
    mut answer: impl FnMut(&str) -> Result<(), Answer>,
) -> Result<usize, EvalError> {
    let mut buf = Vec::new();
    let mut line = 0;
    let mut answered = 0;
    loop {
        buf.clear();
        if input.read_until(b'\n', &mut buf).map_err(EvalError::Read)? == 0 {
            return Ok(answered);
        }
        line += 1;
        let text = std::str::from_utf8(&buf).map_err(|_| EvalError::Line {
            line,
            content: String::from_utf8_lossy(&buf).trim().to_owned(),
            problem: LineProblem::NotUtf8,
        })?;
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        match answer(text) {
            Ok(()) => answered += 1,
            Err(Answer::Line(problem)) => {
                return Err(EvalError::Line {
                    line,
                    content: text.to_owned(),
                    problem,
                });
            }
            Err(Answer::Output(e)) => return Err(e),
        }
    }
}

/// Parses `N` whitespace-separated finite values, each inside its domain.
pub(crate) fn parse_query<const N: usize>(
    text: &str,
    names: [&'static str; N],
    all_names: &'static str,
    domains: [(f32, f32); N],
) -> Result<[f32; N], LineProblem> {
    let words: Vec<&str> = text.split_whitespace().collect();
    if words.len() != N {
        return Err(LineProblem::Count {
            expected: N,
            names: all_names,
            found: words.len(),
        });
    }
    let mut values = [0.0; N];
    for (k, word) in words.iter().enumerate() {
        let name = names[k];
        let value: f32 = word.parse().map_err(|_| LineProblem::NotANumber {
            name,
            text: (*word).to_owned(),
        })?;
        if !value.is_finite() {
            // "1e39" parses to an f32 infinity; it is a number, only not one f32 can hold.
            if word.parse::<f64>().is_ok_and(f64::is_finite) {
                return Err(LineProblem::OutOfF32 {
                    name,
                    text: (*word).to_owned(),
                });
            }
            return Err(LineProblem::NotFinite { name, value });
        }
        let (min, max) = domains[k];
        if !(min..=max).contains(&value) {
            return Err(LineProblem::OutOfDomain {
                name,
                value,
                min,
                max,
            });
        }
        values[k] = value;
    }
    Ok(values)
}

pub(crate) fn write_json<W: Write, T: Serialize>(
    output: &mut W,
    value: &T,
) -> Result<(), EvalError> {
    serde_json::to_writer(&mut *output, value).map_err(|e| EvalError::Write(e.into()))?;
    output.write_all(b"\n").map_err(EvalError::Write)?;
    output.flush().map_err(EvalError::Write)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nurbs::construct;
    use nurbs::{Vec2, Vec3};

    fn run_raw(patch: &Patch, input: &str) -> (Result<usize, EvalError>, String) {
        let mut out = Vec::new();
        let result = run(patch, input.as_bytes(), &mut out);
        (result, String::from_utf8(out).expect("UTF-8 output"))
    }

    fn run_str(patch: &Patch, input: &str) -> (Result<usize, EvalError>, Vec<serde_json::Value>) {
        let (result, text) = run_raw(patch, input);
        let lines = text
            .lines()
            .map(|l| serde_json::from_str(l).expect("each output line is JSON"))
            .collect();
        (result, lines)
    }

    /// The keys of a one-line JSON object in the order written.
    fn keys_in_order(line: &str) -> Vec<String> {
        let value: serde_json::Value = serde_json::from_str(line).expect("JSON");
        let mut keys: Vec<(usize, String)> = value
            .as_object()
            .expect("an object")
            .keys()
            .map(|k| {
                let at = line.find(&format!("\"{k}\":")).expect("key in line");
                (at, k.clone())
            })
            .collect();
        keys.sort();
        keys.into_iter().map(|(_, k)| k).collect()
    }

    fn line_segment() -> Patch {
        Patch::Curve2(
            construct::line(Vec2::new(0.0, 0.1), Vec2::new(0.02, 0.1)).expect("valid line"),
        )
    }

    fn f(v: &serde_json::Value) -> f64 {
        v.as_f64().expect("a number")
    }

    #[test]
    fn curve_lines_and_skipping() {
        let input = "# header\n\n0\n  0.5  \r\n1\n";
        let (_, raw) = run_raw(&line_segment(), input);
        assert_eq!(
            keys_in_order(raw.lines().next().expect("a line")),
            ["u", "p", "du", "duu", "tangent", "normal", "curvature"]
        );
        let (r, out) = run_str(&line_segment(), input);
        assert_eq!(r.expect("all lines valid"), 3);
        assert_eq!(out.len(), 3);
        // A straight segment: p = a + u (b − a), C' = b − a, tangent +x, normal −y, κ = 0.
        assert_eq!(f(&out[1]["u"]), 0.5);
        assert!((f(&out[1]["p"][0]) - 0.01).abs() < 1e-7);
        assert!((f(&out[1]["p"][1]) - 0.1).abs() < 1e-7);
        assert!((f(&out[1]["du"][0]) - 0.02).abs() < 1e-7);
        assert_eq!(f(&out[1]["tangent"][0]), 1.0);
        assert_eq!(f(&out[1]["normal"][1]), -1.0);
        assert_eq!(f(&out[1]["curvature"]), 0.0);
    }

    #[test]
    fn surface_lines() {
        let p00 = Vec3::new(0.0, 0.0, 0.0);
        let p10 = Vec3::new(1.0, 0.0, 0.0);
        let p01 = Vec3::new(0.0, 1.0, 0.0);
        let p11 = Vec3::new(1.0, 1.0, 1.0);
        let patch = Patch::Surface(construct::bilinear(p00, p10, p01, p11).expect("valid"));
        let (_, raw) = run_raw(&patch, "0.25 0.5\n");
        assert_eq!(
            keys_in_order(raw.trim_end()),
            ["u", "v", "p", "du", "dv", "duu", "duv", "dvv", "normal"]
        );
        let (r, out) = run_str(&patch, "0.25 0.5\n");
        assert_eq!(r.expect("valid"), 1);
        // S = (u, v, uv): S_u = (1, 0, v), S_v = (0, 1, u), S_uv = (0, 0, 1).
        let p: Vec<f64> = (0..3).map(|k| f(&out[0]["p"][k])).collect();
        assert_eq!(p, [0.25, 0.5, 0.125]);
        assert_eq!(f(&out[0]["du"][2]), 0.5);
        assert_eq!(f(&out[0]["dv"][2]), 0.25);
        assert_eq!(f(&out[0]["duv"][2]), 1.0);
        // n ∝ S_u × S_v = (−v, −u, 1).
        let n: Vec<f64> = (0..3).map(|k| f(&out[0]["normal"][k])).collect();
        let l = (0.25f64 + 0.0625 + 1.0).sqrt();
        for (a, b) in n.iter().zip([-0.5 / l, -0.25 / l, 1.0 / l]) {
            assert!((a - b).abs() < 1e-6, "{n:?}");
        }
    }

    #[test]
    fn bad_lines_stop_with_the_line_number() {
        let cases: [(&str, &str); 7] = [
            (
                "0.5\n1e39\n",
                "line 2 (\"1e39\"): u: 1e39 is outside the range of f32 (magnitudes up to 3.4028235e38)",
            ),
            (
                "0.5\n1.5\n0.2\n",
                "line 2 (\"1.5\"): u = 1.5 is outside the domain [0, 1]",
            ),
            (
                "0.5\n\n0.1 0.2\n",
                "line 3 (\"0.1 0.2\"): expected 1 value(s) `u`, found 2",
            ),
            ("0.5\nabc\n", "line 2 (\"abc\"): u: \"abc\" is not a number"),
            (
                "0.5\nNaN\n",
                "line 2 (\"NaN\"): u: NaN is not a finite number",
            ),
            (
                "0.5\n-inf\n",
                "line 2 (\"-inf\"): u: -inf is not a finite number",
            ),
            (
                "0.5\n-0.001\n",
                "line 2 (\"-0.001\"): u = -0.001 is outside the domain [0, 1]",
            ),
        ];
        for (input, expected) in cases {
            let (r, out) = run_str(&line_segment(), input);
            let e = r.expect_err("a bad line");
            assert_eq!(e.to_string(), expected);
            assert_eq!(out.len(), 1, "the line before the bad one is answered");
        }
    }

    #[test]
    fn surface_wants_two_values_in_both_domains() {
        let patch = Patch::Surface(
            construct::bilinear(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE).expect("valid"),
        );
        let (r, _) = run_str(&patch, "0.5\n");
        assert_eq!(
            r.expect_err("one value").to_string(),
            "line 1 (\"0.5\"): expected 2 value(s) `u v`, found 1"
        );
        let (r, _) = run_str(&patch, "0.5 2\n");
        assert_eq!(
            r.expect_err("v outside").to_string(),
            "line 1 (\"0.5 2\"): v = 2 is outside the domain [0, 1]"
        );
    }

    /// No answer with a non-finite number is ever written: it is a line error instead.
    #[test]
    fn non_finite_answers_are_refused() {
        let mut sample = sample_curve(
            &construct::line(Vec2::ZERO, Vec2::X).expect("line").view(),
            0.5,
        );
        assert_eq!(sample.check_finite(), Ok(()));
        sample.duu[1] = f32::INFINITY;
        assert_eq!(
            sample.check_finite(),
            Err(LineProblem::Overflow { field: "duu" })
        );
        let mut out = Vec::new();
        assert!(write_answer(&mut out, &sample).is_err());
        assert!(out.is_empty());
    }

    #[test]
    fn invalid_utf8_is_a_line_error() {
        let mut out = Vec::new();
        let e = run(&line_segment(), &b"0\n\xff\n"[..], &mut out).expect_err("bad bytes");
        assert!(e.to_string().starts_with("line 2"), "{e}");
    }
}
