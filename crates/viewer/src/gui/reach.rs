//! Where the device reaches, drawn behind the 2-D view: the default pantograph's reachable
//! cells, their outline, and the guaranteed and safety workspace boxes.

use device::kinematics::Pantograph;
use device::safety::SafetyConfig;
use device::spec::{DeviceSpec, WorkspaceBox};
use nurbs::Vec2;

/// Where the device reaches: a grid over the plane, each cell reachable when the pantograph's
/// inverse kinematics has a solution there with a Jacobian condition number within the
/// device's limit.
#[derive(Clone, Debug, PartialEq)]
pub struct Reach {
    /// Lower-left corner of the grid (m).
    pub origin: Vec2,
    /// Cell size (m).
    pub cell_m: f32,
    /// Cells per row and rows.
    pub size: (usize, usize),
    /// Row-major reachability of the cells' centres.
    pub cells: Vec<bool>,
    /// The outline: the edges between reachable and unreachable cells (m).
    pub outline: Vec<[Vec2; 2]>,
    /// The box the device guarantees to reach ([`DeviceSpec::workspace`]).
    pub guaranteed: WorkspaceBox,
    /// The safety layer's workspace box: leaving it latches the workspace fault.
    pub safety_box: WorkspaceBox,
}

impl Reach {
    /// The reach of the default device on a 2 mm grid.
    pub fn of_default_device() -> Self {
        Self::of_device(&DeviceSpec::default())
    }

    /// The reach of the device `spec` on a 2 mm grid.
    pub fn of_device(spec: &DeviceSpec) -> Self {
        let spec = *spec;
        let arm = spec.pantograph().ok();
        let cell_m = 0.002;
        let origin = Vec2::new(-0.16, -0.02);
        let size = (160, 120);
        let reachable = |p: Vec2| match &arm {
            Some(arm) => reachable(arm, &spec, p),
            None => false,
        };
        let mut cells = Vec::with_capacity(size.0 * size.1);
        for j in 0..size.1 {
            for i in 0..size.0 {
                let c = origin + Vec2::new(i as f32 + 0.5, j as f32 + 0.5) * cell_m;
                cells.push(reachable(c));
            }
        }
        let at = |i: usize, j: usize| cells[j * size.0 + i];
        let mut outline = Vec::new();
        for j in 0..size.1 {
            for i in 0..size.0 {
                let corner = origin + Vec2::new(i as f32, j as f32) * cell_m;
                // Left and bottom edges of every cell, and the grid's own border.
                let left = if i == 0 { false } else { at(i - 1, j) };
                if at(i, j) != left {
                    outline.push([corner, corner + Vec2::new(0.0, cell_m)]);
                }
                let below = if j == 0 { false } else { at(i, j - 1) };
                if at(i, j) != below {
                    outline.push([corner, corner + Vec2::new(cell_m, 0.0)]);
                }
                if i + 1 == size.0 && at(i, j) {
                    let c = corner + Vec2::new(cell_m, 0.0);
                    outline.push([c, c + Vec2::new(0.0, cell_m)]);
                }
                if j + 1 == size.1 && at(i, j) {
                    let c = corner + Vec2::new(0.0, cell_m);
                    outline.push([c, c + Vec2::new(cell_m, 0.0)]);
                }
            }
        }
        Reach {
            origin,
            cell_m,
            size,
            cells,
            outline,
            guaranteed: spec.workspace,
            safety_box: SafetyConfig::default().workspace,
        }
    }

    /// Whether `p` lies in a reachable cell.
    pub fn contains(&self, p: Vec2) -> bool {
        let q = (p - self.origin) / self.cell_m;
        if !(q.x >= 0.0 && q.y >= 0.0) {
            return false;
        }
        let (i, j) = (q.x as usize, q.y as usize);
        i < self.size.0 && j < self.size.1 && self.cells[j * self.size.0 + i]
    }
}

fn reachable(arm: &Pantograph, spec: &DeviceSpec, p: Vec2) -> bool {
    arm.inverse(p)
        .and_then(|theta| arm.jacobian(theta))
        .is_ok_and(|j| j.condition_number() <= spec.max_condition_number)
}
