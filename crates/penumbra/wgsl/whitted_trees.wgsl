// whitted.wgsl's `whitted_trees` entry: shade writes each ray's tree into
// its slot (src/whitted/tree_records.rs).
const RECORD_TREES: bool = true;
