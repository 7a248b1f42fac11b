//! Stage binary: builds `epd_albedo` and `epd_albedo_avg`.
fn main() -> std::process::ExitCode {
    twoscale_cli::main_stage("epd-albedo")
}
