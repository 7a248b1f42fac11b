//! Stage binary: builds `kcorr_renorm`.
fn main() -> std::process::ExitCode {
    twoscale_cli::main_stage("kcorr-renorm")
}
