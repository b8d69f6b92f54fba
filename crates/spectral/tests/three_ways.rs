//! Issue 3 acceptance table: for every process and m ∈ {1, 2, 3, 4, 7, 8, 16, …, 2^20},
//! closed form = Lemma 4.2 sum (≤ 1e-12 relative) = Lemma 4.1 quadrature (≤ 1e-8).
//! Prints the worst gaps per process (`cargo test -p imunoise-spectral --test three_ways
//! -- --nocapture`).

mod common;
use common::fixtures::{RATE, fixtures, m_grid};
use spectral::tolerances::{QUADRATURE_REL, SUM_REL};
use spectral::{allan_variance, lemma42_allan_variance, quadrature_allan_variance};

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn closed_form_lemma42_and_quadrature_agree_for_every_process() {
    eprintln!(
        "{:<28} {:>14} {:>14}",
        "process", "max|sum|rel", "max|quad|rel"
    );
    let (mut all_s, mut all_q) = (0.0f64, 0.0f64);
    for (name, p) in fixtures() {
        let (mut ws, mut wq) = (0.0f64, 0.0f64);
        for m in m_grid() {
            let c = allan_variance(&p, m, RATE).unwrap();
            let s = lemma42_allan_variance(&p, m, RATE).unwrap();
            let q = quadrature_allan_variance(&p, m, RATE).unwrap();
            let (es, eq) = (rel(s, c), rel(q, c));
            assert!(
                es <= SUM_REL,
                "{name} m={m}: closed {c:e} vs Lemma 4.2 {s:e} ({es:e})"
            );
            assert!(
                eq <= QUADRATURE_REL,
                "{name} m={m}: closed {c:e} vs Lemma 4.1 {q:e} ({eq:e})"
            );
            ws = ws.max(es);
            wq = wq.max(eq);
        }
        eprintln!("{name:<28} {ws:>14.2e} {wq:>14.2e}");
        all_s = all_s.max(ws);
        all_q = all_q.max(wq);
    }
    eprintln!("{:<28} {all_s:>14.2e} {all_q:>14.2e}", "all");
}
