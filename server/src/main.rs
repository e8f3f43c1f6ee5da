//! `spindle-server`: parses the command line, sets up logging, binds (the API, and the dashboard
//! when asked), and runs the coordinator
//! until Ctrl-C or SIGTERM.

use anyhow::Context;
use spindle_server::Args;

fn main() -> std::process::ExitCode {
    // An error that stops the coordinator is told as a sentence (its causes after colons),
    // never as a debug dump with a backtrace.
    match serve() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("spindle-server: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

#[tokio::main]
async fn serve() -> anyhow::Result<()> {
    let args = Args::from_process();
    spindle_server::logging::init(args.log_format);
    let (listen, dashboard_listen) = (args.listen, args.dashboard_listen);
    let config = args.into_config()?;
    let listener = tokio::net::TcpListener::bind(listen)
        .await
        .with_context(|| format!("binding {listen}"))?;
    let dashboard = match dashboard_listen {
        Some(addr) => Some(
            tokio::net::TcpListener::bind(addr)
                .await
                .with_context(|| format!("binding --dashboard-listen {addr}"))?,
        ),
        None => None,
    };
    spindle_server::run_with_dashboard(config, listener, dashboard, shutdown_signal()).await
}

async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = terminate => {}
    }
}
