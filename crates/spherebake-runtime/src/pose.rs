//! Posing: sphere centres from joint matrices (Ren et al. 2006 §6.2 "Animation"; the bake folds
//! mean value coordinates and skin weights into per-bone homogeneous points, math reference §7).
//!
//! The posed centre of sphere `s` is `Σ_j M_j · (q_j, b_j)` over its skin slots, `M_j` the joint
//! matrix of the slot's bone in the glTF convention (joint world transform × inverse bind
//! matrix, column-major `[f32; 16]`, element (row r, column c) at `4c + r`). Radii are kept.

use crate::{refit, HierarchyPlan, Proxy, QueryError, Sphere};

static ZERO_MATRIX: [f32; 16] = [0.0; 16];

/// Why [`pose`] refused its arguments (nothing is written then).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum PoseError {
    /// Fewer joint matrices than bones in the proxy's bone table.
    JointCount {
        /// Bones in the bone table.
        expected: usize,
        /// Matrices given.
        actual: usize,
    },
    /// `out` does not hold exactly one sphere per proxy sphere.
    OutputLength {
        /// Spheres in the proxy.
        expected: usize,
        /// Length of `out`.
        actual: usize,
    },
    /// The hierarchy refit of [`pose_and_refit`] refused its slices.
    Refit(QueryError),
}

impl core::fmt::Display for PoseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PoseError::JointCount { expected, actual } => {
                write!(f, "pose: {actual} joint matrices given, the bone table needs {expected}")
            }
            PoseError::OutputLength { expected, actual } => {
                write!(f, "pose: output holds {actual} spheres, expected {expected}")
            }
            PoseError::Refit(e) => write!(f, "pose: hierarchy refit: {e}"),
        }
    }
}

impl core::error::Error for PoseError {}

/// Poses every sphere: `out[s].center = Σ_j M_j · (q_j, b_j)` (xyz part) over sphere `s`'s skin
/// slots, `out[s].radius` = the stored radius. A proxy without a skin section copies its rest
/// spheres. Allocation-free; f32 arithmetic, slots in stored order.
///
/// `joint_matrices[j]` is bone `j`'s joint matrix, glTF convention (world(joint) × inverse bind,
/// column-major); extra matrices are ignored. Follow with [`crate::refit`] to update the
/// hierarchy's node spheres.
///
/// # Errors
///
/// [`PoseError::JointCount`] when fewer matrices than bones are given (only checked for a proxy
/// with a skin), [`PoseError::OutputLength`] when `out.len() != proxy.sphere_count()`.
pub fn pose(proxy: &Proxy, joint_matrices: &[[f32; 16]], out: &mut [Sphere]) -> Result<(), PoseError> {
    let rest = proxy.spheres();
    if out.len() != rest.len() {
        return Err(PoseError::OutputLength { expected: rest.len(), actual: out.len() });
    }
    let Some(skin) = proxy.skin() else {
        out.copy_from_slice(rest);
        return Ok(());
    };
    let bone_count = proxy.bones().len();
    if joint_matrices.len() < bone_count {
        return Err(PoseError::JointCount { expected: bone_count, actual: joint_matrices.len() });
    }
    let k = skin.bones_per_sphere as usize;
    if k == 0 {
        out.copy_from_slice(rest);
        return Ok(());
    }
    // `load` validated: entries.len() == sphere count × k, every used bone < bone count.
    for ((o, r), slots) in out.iter_mut().zip(rest).zip(skin.entries.chunks_exact(k)) {
        // Four lanes (the w row rides along) so the compiler can use one SIMD register per column.
        let mut acc = [0.0f32; 4];
        for e in slots {
            // Unused slots (bone UNUSED_BONE, out of range) read the zero matrix: no branch.
            let m = joint_matrices.get(e.bone as usize).unwrap_or(&ZERO_MATRIX);
            let [qx, qy, qz] = e.q;
            let b = e.b;
            for (i, a) in acc.iter_mut().enumerate() {
                *a += m[i] * qx + m[4 + i] * qy + m[8 + i] * qz + m[12 + i] * b;
            }
        }
        let [x, y, z, _] = acc;
        *o = Sphere { center: [x, y, z], radius: r.radius };
    }
    Ok(())
}

/// [`pose`] followed by the hierarchy refit ([`crate::refit`]): `leaves_out` gets the posed
/// spheres, `nodes_out` the refitted node spheres (build `plan` once with
/// [`Proxy::hierarchy_plan`], size `nodes_out` with [`HierarchyPlan::node_count`]).
/// Allocation-free.
///
/// # Errors
///
/// Those of [`pose`]; [`PoseError::Refit`] when `nodes_out` does not match the plan.
pub fn pose_and_refit(
    proxy: &Proxy,
    plan: &HierarchyPlan,
    joint_matrices: &[[f32; 16]],
    leaves_out: &mut [Sphere],
    nodes_out: &mut [Sphere],
) -> Result<(), PoseError> {
    pose(proxy, joint_matrices, leaves_out)?;
    refit(plan, leaves_out, nodes_out).map_err(PoseError::Refit)
}
