//! Caustic photons (method.md §2, §3): the compact photon record and the kd-tree with its k-NN query,
//! and the occupancy grid that answers "no photon within the search radius" without a search.
//! Emission and delta-chain tracing live beside them.

pub mod counts;
pub mod dirbox;
pub mod emission;
pub mod emit;
pub mod kdtree;
pub mod occupancy;
pub mod record;

pub use kdtree::{KdTree, KdTreeError, KnnMemory, KnnResult, LeavesNear, Neighbor, SearchFrom};
pub use emit::{light_emits_photons, longest_chain, photon_chain_reaches, trace_photons, PhotonBudget, PhotonMap, PhotonPassStats, MAX_DELTA_CHAIN};
pub use emission::PhotonEmission;
pub use counts::PhotonCounts;
pub use dirbox::DirBox;
pub use occupancy::{CellAt, Near, OccupancyGrid, PhotonsNear};
pub use record::{DecodedPhoton, Photon, PhotonList};
