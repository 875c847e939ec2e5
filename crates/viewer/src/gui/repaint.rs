//! When the app draws again without input: at the display's pace while something moves, at a
//! few frames a second while the loop runs on with nothing changing (the plots' time axis,
//! the tick statistics), so that an idle app does not spend a core redrawing the same
//! picture under a software rasteriser. egui draws at once on any input (the pointer, keys).

use std::time::Duration;

use friction::Mode;
use nurbs::Vec3;

use super::state::AppState;

/// The pace while something moves: about 60 frames a second (a display's vsync may slow it).
pub const ACTIVE_FRAME: Duration = Duration::from_millis(15);

/// The pace while the loop runs with nothing moving: 2 frames a second, enough for the plots
/// and counters to stay current.
pub const IDLE_FRAME: Duration = Duration::from_millis(500);

/// How far the handle moves before it is drawn again at once (m): 50 µm, more than two
/// encoder counts of the default device at the handle (19.6 µm each), so that a board's
/// one-count noise at rest does not keep the app at full pace.
pub const VISIBLE_MOVE_M: f32 = 5e-5;

/// How much the force changes before it is drawn again at once (N): that noise through a
/// K = 1000 N/m wall is 0.02 N a count.
pub const VISIBLE_FORCE_N: f32 = 0.05;

/// What the last frame showed of the newest tick.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Shown {
    hip: Vec3,
    force: Vec3,
    mode: Mode,
    forces_enabled: bool,
    faults: u16,
}

/// The app's repaint pace: remembers what was drawn and says when to draw again.
#[derive(Clone, Debug, Default)]
pub struct Repaint {
    shown: Option<Shown>,
}

impl Repaint {
    /// After a frame of `state`: how soon to draw the next one with no input. At
    /// [`ACTIVE_FRAME`] while the hand is dragged, a replay or demo plays, or the newest tick
    /// differs visibly from the one the previous frame showed (the handle moved by
    /// [`VISIBLE_MOVE_M`], the force by [`VISIBLE_FORCE_N`], the mode, the forces switch or
    /// the faults changed); at [`IDLE_FRAME`] otherwise.
    pub fn after_frame(&mut self, state: &AppState, animating: bool) -> Duration {
        let now = state.latest().map(|s| Shown {
            hip: s.tick.hip,
            force: s.tick.force,
            mode: s.tick.mode,
            forces_enabled: s.forces_enabled,
            faults: s.tick.device.map_or(0, |d| d.faults),
        });
        let changed = match (self.shown, now) {
            (Some(a), Some(b)) => {
                (a.hip - b.hip).length_squared() > VISIBLE_MOVE_M * VISIBLE_MOVE_M
                    || (a.force - b.force).length_squared() > VISIBLE_FORCE_N * VISIBLE_FORCE_N
                    || (a.mode, a.forces_enabled, a.faults) != (b.mode, b.forces_enabled, b.faults)
            }
            (None, None) => false,
            _ => true,
        };
        // Only a frame that showed a change moves the reference on, so a slow creep (a
        // glide, a settling handle) adds up to a redraw.
        if changed {
            self.shown = now;
        }
        let playing = state.replay.as_ref().is_some_and(|r| r.playing);
        if changed || animating || playing || state.dragging {
            ACTIVE_FRAME
        } else {
            IDLE_FRAME
        }
    }
}
