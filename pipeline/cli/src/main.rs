//! `twoscale`: every command (see pipeline/cli/src/commands/).
fn main() -> std::process::ExitCode {
    twoscale_cli::main_twoscale()
}
