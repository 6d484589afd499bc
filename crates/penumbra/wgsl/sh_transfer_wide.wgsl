// The workgroup arrays of `sh_transfer.wgsl` for devices with 32 KiB of
// workgroup memory (lavapipe, desktop GPUs): 16 vertices a workgroup at
// most, 29,696 bytes.

const MAX_VERTS: u32 = 16u;
// Staged mask words (vertices x words) and cells (vertices x cells).
const STAGED: u32 = 1024u;
