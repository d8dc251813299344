//! Ctrl-C (SIGINT): the first one asks the running render to stop at the next pass and keep what it
//! rendered (the command then exits with 130, the shell's code for SIGINT); a second one aborts at once.

use focal_render::render::cancel::CancelFlag;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// The exit code of a command that was interrupted (128 + SIGINT), as shells report it.
pub const EXIT_INTERRUPTED: u8 = 130;

static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// Installs the handler (once per process) and returns the flag it raises, for the render loops.
pub fn install() -> CancelFlag {
    let flag = FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let raised = flag.clone();
        let installed = ctrlc::set_handler(move || {
            if raised.swap(true, Ordering::SeqCst) {
                eprintln!("\nfocal: interrupted again, aborting");
                std::process::exit(EXIT_INTERRUPTED as i32);
            }
            eprintln!(
                "\nfocal: interrupted, finishing with the samples rendered so far \
                 (Ctrl-C again to abort)"
            );
        });
        if let Err(e) = installed {
            eprintln!("warning: Ctrl-C will abort without saving ({e})");
        }
        flag
    });
    CancelFlag::new(flag.clone())
}

/// True once Ctrl-C was pressed.
pub fn interrupted() -> bool {
    FLAG.get().is_some_and(|f| f.load(Ordering::SeqCst))
}
