use std::path::PathBuf;

fn main() {
    // TEMPORARY until the CLI (clap: info, deform, bench, edit) lands from main.
    let mesh = std::env::args_os().nth(1).map(PathBuf::from);
    if let Err(e) = app::editor::run(mesh) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
