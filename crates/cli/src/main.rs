//! `focal`: render Mitsuba scenes, benchmark the path tracer. Thin: all the work is in `focal-render`.

mod bench;
mod compare_args;
mod compare_checks;
mod compare_cmd;
mod convergence_plot;
mod fireflies_cmd;
mod flip;
mod guiding_args;
mod input_checks;
mod interrupt;
mod json_out;
mod merge_cmd;
mod metrics_cmd;
mod reference_cmd;
mod render_args;
mod render_cmd;
mod render_output;
mod report_html;
mod shard;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// focal — a research path tracer for focal path guiding.
#[derive(Parser)]
#[command(name = "focal", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a Mitsuba 0.6 / 3 XML scene to EXR (and optionally PNG), with a JSON sidecar.
    Render(render_args::RenderArgs),
    /// Measure path-tracing throughput (samples/s) on the reference scenes.
    Bench(bench::BenchArgs),
    /// Render a scene with several methods at equal time or spp and tabulate their errors.
    Compare(compare_args::CompareArgs),
    /// Error metrics (relMSE, MSE, MAPE, SMAPE, LDR-FLIP) of an image against a reference.
    Metrics(metrics_cmd::MetricsArgs),
    /// A long, resumable (checkpointed) unguided reference render with its per-pixel variance.
    Reference(reference_cmd::ReferenceArgs),
    /// Combine independent renders of one scene, weighted by their sample counts.
    Merge(merge_cmd::MergeArgs),
    /// List the samples of a render with a trained guide that carry its error, with their paths.
    Fireflies(fireflies_cmd::FirefliesArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render_cmd::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Metrics(a) => metrics_cmd::run(a),
        Command::Compare(a) => compare_cmd::run(a),
        Command::Reference(a) => reference_cmd::run(a),
        Command::Merge(a) => merge_cmd::run(a),
        Command::Fireflies(a) => fireflies_cmd::run(a),
    };
    if let Err(e) = &result {
        eprintln!("error: {e:#}");
    }
    // Ctrl-C stopped the work (what was done is written): the shell's code for SIGINT.
    if interrupt::interrupted() {
        return ExitCode::from(interrupt::EXIT_INTERRUPTED);
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(_) => ExitCode::FAILURE,
    }
}
