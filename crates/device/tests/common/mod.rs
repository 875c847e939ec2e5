//! Helpers the device's safety and wall-acceptance tests share.

use device::wall::{AtHandle, PassivityConfig};

/// A device with b = 0.005 N·s/m, f_c = 0.02 N and Δ = 20 µm at the handle, the bound
/// covering impacts up to v = 0.1 m/s: b + f_c / v = 0.205 N·s/m.
pub fn device(b: f32, f_c: f32, delta: f32) -> PassivityConfig {
    PassivityConfig {
        device: AtHandle {
            damping_n_s_per_m: b,
            coulomb_n: f_c,
            resolution_m: delta,
        },
        impact_speed_m_per_s: 0.1,
        controller_stiffness_n_per_m: 1000.0,
        controller_damping_ns_per_m: 1.0,
        output_delay_ticks: 0,
    }
}
