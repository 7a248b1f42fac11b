//! Stage binary: builds `kcorr_renorm`.
fn main() -> std::process::ExitCode {
    twoscale::cli::main_stage("kcorr-renorm")
}
