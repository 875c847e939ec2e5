//! The participant screen of a psychophysics run (thesis §4.3): `viewer experiment run PLAN
//! --participant P01 --out DIR [--device …]` opens the app in this mode.
//!
//! [`ParticipantRun`] is the run's logic, apart from the drawing: an
//! [`experiment::session::Session`] (which writes `DIR/trials.csv` and resumes a folder at its
//! next trial) and the phase of the trial in progress. It loads each trial's scene into the
//! app's haptic loop through [`AppState`](crate::gui::state::AppState)'s own scene swap (the path that uploads to a
//! connected device), switches the stimulus on (forces on) once the loop took it and off
//! (forces off) when the exploration ends, and keeps every tick the UI takes in while the
//! stimulus is on, written at the answer as the trial's run logs `DIR/traces/trial-NNNN-a.csv`
//! (and `-b.csv` for the second interval of a 2AFC trial), in the columns of the app's
//! `--record` run log. Its clock is the caller's (`now_s`, seconds), so tests drive it
//! without a window.
//!
//! [`ParticipantUi`] draws it: the trial's number and progress, the exploration timer, the
//! hand's cursor and nothing of the object (no curve, no contact point, no god-object, no
//! force arrow, no friction-mode colour), and the answer panel.
//!
//! Keys: `1`/`2` feel interval 1 or 2 (2AFC, while exploring); Enter ends the exploration,
//! goes on after a practice trial's feedback, and starts or resumes; `1`…`9` name a stimulus
//! (identification, when answering); `F`/`←` "first", `S`/`→` "second" (2AFC, when
//! answering); `P` pauses and resumes, Esc pauses.
//!
//! The runtime is in `run` and the screen in `screen`; their items are this module's.

mod run;
mod screen;

pub use run::*;
pub use screen::*;
