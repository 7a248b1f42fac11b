//! Stage binary: builds `epd_g1` and `epd_norm`.
fn main() -> std::process::ExitCode {
    twoscale_cli::main_stage("epd-g1")
}
