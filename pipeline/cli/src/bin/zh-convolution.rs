//! Stage binary: builds `zh_convolution`.
fn main() -> std::process::ExitCode {
    twoscale_cli::main_stage("zh-convolution")
}
