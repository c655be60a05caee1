//! The scorecard at the top of docs/validation.md is generated from committed data by
//! `examples/papers/scorecard.py`: this test fails when the page's table differs from what the
//! script computes from the committed data (someone edited a number by hand, or committed new data
//! without regenerating the page), when the page cites a repository file that does not exist, or
//! when the script's verdict rules stop doing what the page says they do (its self-test).
//!
//! The script needs only Python 3's standard library; where `python3` cannot be started the test
//! says so on standard error and passes (as the other tests that use Python readers do).

use std::path::Path;
use std::process::Command;

fn script(args: &[&str]) -> Option<std::process::Output> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    match Command::new("python3").arg("examples/papers/scorecard.py").args(args).current_dir(&root).output() {
        Ok(out) => Some(out),
        Err(e) => {
            eprintln!("skipped: python3 cannot be started ({e}); the scorecard of docs/validation.md was not checked");
            None
        }
    }
}

#[test]
fn the_scorecard_verdict_rules_do_what_the_page_says() {
    if let Some(out) = script(&["--self-test"]) {
        assert!(out.status.success(), "scorecard.py --self-test failed:\n{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    }
}

#[test]
fn the_validation_page_scorecard_is_the_one_the_committed_data_give() {
    if let Some(out) = script(&["--check"]) {
        assert!(
            out.status.success(),
            "docs/validation.md is out of date or cites missing files (regenerate with `python3 examples/papers/scorecard.py --write`):\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
