"""The seed paper's section 4, item by item (docs/paper-reproduction.md): which runs each item
needs (:mod:`analysis.paper.runs`), running them (:mod:`analysis.paper.measure`) and the verdict
of each claim, computed from the measured numbers (:mod:`analysis.paper.verdicts`)."""
