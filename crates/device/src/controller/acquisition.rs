//! The global closest-point search that starts a renderer, run outside the tick (see the
//! controller's module docs, "Acquisition is not the tick's").

use nurbs::Vec2;
use tracker::Object;

#[cfg(doc)]
use super::Controller;

/// What an acquisition searches from: the HIP of the last tick and the scene it is for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AcquisitionRequest {
    /// The HIP (device frame, m) the global closest-point search starts from.
    pub hip_m: Vec2,
    /// The scene's generation: it changes with every [`Controller::load_scene`],
    /// [`Controller::set_material`] and [`Controller::unload_scene`], so a search finished
    /// after a swap is refused.
    pub generation: u32,
}

/// The result of [`acquire`], for [`Controller::complete_acquisition`].
#[derive(Clone, Copy, Debug)]
pub struct Acquisition<S> {
    pub(super) state: S,
    pub(super) generation: u32,
}

/// The global closest-point search that starts a renderer on `object` at the request's HIP
/// ([`tracker::Object::start`]): the slow part of a scene swap, run outside the tick (see the
/// module docs). Bounded, no allocation, no panic.
pub fn acquire<O: Object<P = Vec2>>(
    object: &O,
    request: AcquisitionRequest,
) -> Acquisition<O::State> {
    Acquisition {
        state: object.start(request.hip_m, friction::cp_config()),
        generation: request.generation,
    }
}
