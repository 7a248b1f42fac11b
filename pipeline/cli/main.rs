fn main() -> std::process::ExitCode {
    twoscale_cli::main_twoscale()
}
