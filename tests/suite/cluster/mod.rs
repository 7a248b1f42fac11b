//! Clusters: plans, shards and their merge, a SLURM array job.

mod plan;
mod shards;
mod slurm;
