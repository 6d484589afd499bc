// whitted.wgsl's pixel entries (`whitted`, `whitted_listed`): shade
// records no ray tree. The recording, even behind a branch never taken (or
// a pipeline-overridable constant set to false), made lavapipe run the
// pixel entries 18 times slower, so it is compiled out here.
const RECORD_TREES: bool = false;
