//! Plots a finished run: `cargo run -p clearance-plot --example plot_dir -- DIR [OUT]`
//! (OUT defaults to DIR/plots), the library side of `clearance plot`.

use std::path::PathBuf;

fn main() {
    let mut args = std::env::args_os().skip(1);
    let Some(dir) = args.next().map(PathBuf::from) else {
        eprintln!("usage: plot_dir DIR [OUT]");
        std::process::exit(2);
    };
    let out = args.next().map(PathBuf::from).unwrap_or_else(|| dir.join("plots"));
    match clearance_plot::plot_run(&dir, &out) {
        Ok(files) => files.iter().for_each(|f| println!("{}", f.display())),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
