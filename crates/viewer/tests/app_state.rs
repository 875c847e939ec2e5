//! The app's scene tree and material editor, through its state (no window).

use friction::{ModelKind, Stribeck};
use viewer::gui::state::AppState;

/// The first planar object is rendered on open; asking for another planar one renders it
/// (its material becomes the running one), and a surface is refused with the pantograph's
/// reason, leaving the running object.
#[test]
fn another_object_of_the_scene_can_be_rendered() {
    let mut state = AppState::stepped("examples").unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(state.scene.rendered, Some(0));
    let circle = state.source.objects()[1].material().friction_material();
    state.render_object(1);
    state.step(1);
    assert_eq!(state.scene.rendered, Some(1));
    assert_eq!(state.running_material, Some(circle));
    assert_eq!(state.scene_error, None);
    state.render_object(2);
    let e = state.scene_error.clone().expect("a surface is refused");
    assert!(e.contains("not a chain of planar curves"), "{e}");
    assert_eq!(state.scene.rendered, Some(1));
}

/// The friction model and the Stribeck shape are edited like the numbers: a valid choice
/// reaches the loop (the running material reports it), an invalid one (a zero exponent)
/// is named and the running material stays.
#[test]
fn the_model_and_the_stribeck_shape_are_editable() {
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    state.edited_material.model = ModelKind::Karnopp;
    state.edited_material.viscous_ns_per_m = 0.5;
    state.edited_material.stribeck = Stribeck::Power { exponent: 3 };
    state.apply_material();
    state.step(1);
    let running = state.running_material.expect("running");
    assert_eq!(running.model, ModelKind::Karnopp);
    assert_eq!(running.stribeck, Stribeck::Power { exponent: 3 });
    assert_eq!(running.viscous_ns_per_m, 0.5);
    state.edited_material.stribeck = Stribeck::Power { exponent: 0 };
    state.apply_material();
    let e = state.material_error.clone().expect("refused");
    assert!(e.contains("exponent") || e.contains("stribeck"), "{e}");
    assert_eq!(
        state.running_material.map(|m| m.stribeck),
        Some(Stribeck::Power { exponent: 3 })
    );
}
