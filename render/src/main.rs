//! The `render` binary: see [`render::run`].

fn main() -> std::process::ExitCode {
    match render::run(std::env::args_os()) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("render: error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
