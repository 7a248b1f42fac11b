fn main() -> std::process::ExitCode {
    twoscale::cli::main_twoscale()
}
