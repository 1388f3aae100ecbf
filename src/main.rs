//! The `crackle` command line (the library's `cli` feature): parses
//! arguments, runs a command, maps errors to exit codes (0 ok, 1 processing
//! failed, 2 bad usage or configuration).

fn main() -> std::process::ExitCode {
    crackle::command_line()
}
