// The workgroup arrays of `sh_transfer.wgsl` within WebGPU's portable
// `max_compute_workgroup_storage_size` (16 KiB): 8 vertices a workgroup at
// most, 14,848 bytes.

const MAX_VERTS: u32 = 8u;
// Staged mask words (vertices x words) and cells (vertices x cells).
const STAGED: u32 = 512u;
