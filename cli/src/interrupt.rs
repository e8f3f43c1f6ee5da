//! Ctrl-C, SIGTERM and SIGHUP during `spindle render`: what a person stopping a long render
//! expects is the work done so far on disk, not a lost hour.
//!
//! The first SIGINT or SIGTERM asks the render to stop: it writes what is done to the output
//! (the tiles that are in, the missing ones transparent black; or the last complete
//! progressive pass) and the command exits with 128 + the signal's number (130, 143), as
//! shells expect of a process a signal ended. A second one quits at once, writing nothing,
//! after removing the local farm's data directory. SIGHUP writes the image so far and the
//! render goes on (as Mitsuba's command line does).
//!
//! Tokio's own signal handling (`tokio::signal::unix`) rather than a crate of its own: the
//! local farm waits on the runtime already, where a signal is one more branch of a `select!`,
//! and the in-process render reads the state between tiles.

use std::path::PathBuf;
use std::sync::{Arc, Mutex, PoisonError};

use anyhow::{Context, Result};
use tokio::signal::unix::{SignalKind, signal};
use tokio::sync::watch;

/// A signal that stops the render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// SIGINT (Ctrl-C).
    Interrupt,
    /// SIGTERM.
    Terminate,
}

impl Stop {
    pub fn name(self) -> &'static str {
        match self {
            Stop::Interrupt => "SIGINT",
            Stop::Terminate => "SIGTERM",
        }
    }

    /// 128 + the signal's number, the status a shell reports for a process the signal ended.
    pub fn exit_code(self) -> u8 {
        match self {
            Stop::Interrupt => 128 + 2,
            Stop::Terminate => 128 + 15,
        }
    }
}

/// What the signals received so far ask for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Asked {
    /// The first stopping signal, once one came.
    pub stop: Option<Stop>,
    /// SIGHUPs received: each asks for the image so far.
    pub hangups: u64,
}

/// The render ended early on a signal, having written what was done: `main` prints it and
/// exits with [`Stop::exit_code`].
#[derive(Debug, thiserror::Error)]
#[error("interrupted by {}: {what}", signal.name())]
pub struct Interrupted {
    pub signal: Stop,
    /// What was written, and where.
    pub what: String,
}

/// The signals a render listens to, from [`Signals::listen`] until the process ends.
#[derive(Debug, Clone)]
pub struct Signals {
    asked: watch::Receiver<Asked>,
    /// Removed before a second stopping signal ends the process (the local farm's data).
    remove_on_quit: Arc<Mutex<Option<PathBuf>>>,
}

impl Signals {
    /// Takes over SIGINT, SIGTERM and SIGHUP for the rest of the process (on the current
    /// runtime).
    pub fn listen() -> Result<Signals> {
        let listen = |kind: SignalKind| signal(kind).context("listening for signals");
        let mut interrupt = listen(SignalKind::interrupt())?;
        let mut terminate = listen(SignalKind::terminate())?;
        let mut hangup = listen(SignalKind::hangup())?;
        let (tell, asked) = watch::channel(Asked::default());
        let remove_on_quit = Arc::new(Mutex::new(None::<PathBuf>));
        let remove = remove_on_quit.clone();
        tokio::spawn(async move {
            loop {
                let stop = tokio::select! {
                    _ = interrupt.recv() => Stop::Interrupt,
                    _ = terminate.recv() => Stop::Terminate,
                    _ = hangup.recv() => {
                        tell.send_modify(|a| a.hangups += 1);
                        continue;
                    }
                };
                if tell.borrow().stop.is_some() {
                    quit_at_once(stop, &remove);
                }
                eprintln!(
                    "spindle: {}: stopping, writing what is done ({} again quits at once)",
                    stop.name(),
                    stop.name()
                );
                tell.send_modify(|a| a.stop = Some(stop));
            }
        });
        Ok(Signals {
            asked,
            remove_on_quit,
        })
    }

    /// What has been asked so far.
    pub fn asked(&self) -> Asked {
        *self.asked.borrow()
    }

    /// A receiver that wakes on each signal (`changed()`), for a `select!`.
    pub fn watch(&self) -> watch::Receiver<Asked> {
        self.asked.clone()
    }

    /// `dir` is removed if a second signal ends the process at once; `None` once it is gone.
    pub fn remove_on_quit(&self, dir: Option<PathBuf>) {
        *self
            .remove_on_quit
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = dir;
    }
}

/// The second stopping signal: no more waiting for anything.
fn quit_at_once(stop: Stop, remove: &Mutex<Option<PathBuf>>) -> ! {
    if let Some(dir) = remove.lock().unwrap_or_else(PoisonError::into_inner).take() {
        let _ = std::fs::remove_dir_all(dir);
    }
    eprintln!("spindle: {} again: quit, nothing written", stop.name());
    std::process::exit(i32::from(stop.exit_code()))
}

/// `wrote 12 of 40 tiles to OUT (the 28 others transparent black, alpha 0)`.
pub fn tiles_written(done: usize, total: usize, output: &std::path::Path) -> String {
    let missing = total.saturating_sub(done);
    format!(
        "wrote {done} of {total} tiles to {} (the {missing} others transparent black, alpha 0)",
        output.display()
    )
}
