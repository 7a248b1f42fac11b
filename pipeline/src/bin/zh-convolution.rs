//! Stage binary: builds `zh_convolution`.
fn main() -> std::process::ExitCode {
    twoscale::cli::main_stage("zh-convolution")
}
