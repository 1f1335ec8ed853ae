//! The `facebake` command: see `facebake --help` and [`facebake::cli`].

fn main() -> std::process::ExitCode {
    facebake::cli::main()
}
