//! Topology report: counts, bounds, boundary / non-manifold edges, components, volume.
//! (Filled in by the io/topology work.)

/// Topology facts about a mesh, on welded positions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TopologyReport {}
