//! The `imunoise` command: see `imunoise --help`.

use clap::Parser;

fn main() {
    let cli = imunoise::cli::Cli::parse();
    if let Err(e) = imunoise::cli::run(cli) {
        // A closed pipe (`imunoise avar … | head`) is not an error of ours.
        if e.is_broken_pipe() {
            return;
        }
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}
