//! The `imunoise` command (being built: see the CLI issue).
fn main() {
    println!("imunoise");
}
