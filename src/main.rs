//! The `imunoise` command: see `imunoise --help`.

use clap::Parser;

fn main() {
    let cli = imunoise::cli::Cli::parse();
    if let Err(e) = imunoise::cli::run(cli) {
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}
