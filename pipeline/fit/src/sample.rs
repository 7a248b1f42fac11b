//! One measured sample as the fit takes it, whatever file it came from (`measured` reads the files).

/// One measured sample above the horizon.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Unit vectors in the local frame (z the normal), wi the file's incident direction.
    pub wi: [f64; 3],
    pub wo: [f64; 3],
    /// rho (1/sr) per channel, red, green, blue.
    pub rho: [f64; 3],
    /// Its lobe node, an index into `Measured::nodes`.
    pub node: u32,
    /// A key unique in the file and fixed by it (the bin or grid node): subsamples are drawn by its
    /// hash, so that the same file gives the same subsample whatever the thread count.
    pub key: u64,
    /// The solid-angle measure dwi dwo the sample stands for, relative (the file's sampling density's
    /// inverse): what a sample weighs in an integral over direction pairs.
    pub measure: f64,
}
