fn main() {
    println!("xtask: no tasks yet");
}
