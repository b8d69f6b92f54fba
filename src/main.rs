//! The `imunoise` command: see `imunoise --help`.

use clap::Parser;

fn main() {
    let cli = imunoise::cli::Cli::parse();
    if let Err(e) = imunoise::cli::run(cli) {
        // A closed pipe (`imunoise avar … | head`) is not an error of ours.
        if let imunoise::Error::Io { source, .. } = &e
            && source.kind() == std::io::ErrorKind::BrokenPipe
        {
            return;
        }
        eprintln!("error: {e}");
        std::process::exit(e.exit_code());
    }
}
