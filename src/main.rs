//! The `softsense` command line: parses arguments and calls the library.
fn main() {
    eprintln!("softsense: the command line is being built (issue 2)");
    std::process::exit(2);
}
