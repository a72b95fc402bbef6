//! `bsarap`: the BS-ARAP editor and its headless subcommands (info, deform, bench, export,
//! render, subdivide).
//!
//! This file is glue: argument parsing (clap) and error reporting. The work is in `solver`
//! (numerics, IO) and in the modules below.

mod cli;

use clap::{CommandFactory, FromArgMatches};
use std::process::ExitCode;

fn main() -> ExitCode {
    let parsed = cli::Cli::command()
        .try_get_matches()
        .and_then(|m| cli::Cli::from_arg_matches(&m).map(|args| (args, m)));
    let (args, matches) = match parsed {
        Ok(a) => a,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                print!("{e}");
                return ExitCode::SUCCESS;
            }
            if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                print!("{e}");
                return ExitCode::from(2);
            }
            // One line: clap's first paragraph names the argument and the problem.
            let text = e.render().to_string();
            let first: Vec<&str> =
                text.lines().take_while(|l| !l.trim().is_empty()).map(str::trim).collect();
            eprintln!("{}", first.join(" "));
            return ExitCode::from(2);
        }
    };
    match cli::run(args, &matches) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A solve that went non-finite stopped the command before it wrote anything.
            let non_finite = e.chain().any(|c| {
                matches!(c.downcast_ref(), Some(solver::SolveError::NonFiniteResult { .. }))
            });
            let written = if non_finite { "; nothing was written" } else { "" };
            eprintln!("error: {}{written}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, `: ` between them, as anyhow's `{:#}` writes them, but
/// each cause once: a message that already quotes its cause (the solver's errors do, so that a
/// status bar showing one message says everything) does not repeat it.
fn one_line(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let message = cause.to_string();
        if !out.contains(&message) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&message);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::one_line;

    /// An error that quotes its cause, as the solver's do.
    #[derive(Debug)]
    struct Quoting(std::io::Error);

    impl std::fmt::Display for Quoting {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "scene s.json: handles: {}", self.0)
        }
    }

    impl std::error::Error for Quoting {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    /// A cause its error already quotes is written once; context and other causes are kept.
    #[test]
    fn causes_are_written_once() {
        let io = std::io::Error::other("sphere 0 contains no vertex");
        let e = anyhow::Error::new(Quoting(io)).context("render");
        assert_eq!(one_line(&e), "render: scene s.json: handles: sphere 0 contains no vertex");
        let e = anyhow::Error::new(std::io::Error::other("no such file")).context("reading m.obj");
        assert_eq!(one_line(&e), "reading m.obj: no such file");
    }
}
