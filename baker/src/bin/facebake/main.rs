//! The `facebake` command: see `facebake --help`. The command line maps arguments to the
//! library's options and prints what it returns.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
