fn main() {
    std::process::exit(coapt::cli::main());
}
