//! `twoscale`: every command (see pipeline/cli/commands/).
fn main() -> std::process::ExitCode {
    twoscale_cli::main_twoscale()
}
