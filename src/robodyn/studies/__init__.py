"""Studies built on simulation: work-precision bench, stability, exactness proofs, report text."""
