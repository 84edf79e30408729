"""Fitting a family's law to data, and sampling its posterior.

One package for the calibration of every transmission family (:doc:`/guide/architecture`):

* what is written once: :mod:`~tendon_id.calibration.run` (``tendon-id calibrate``: fit, files,
  posterior), :mod:`~tendon_id.calibration.posterior` (walkers, emcee, diagnostics),
  :mod:`~tendon_id.calibration.mcmc` (ArviZ's ESS and R-hat) and
  :mod:`~tendon_id.calibration.optimize` (the one place nlopt is called);
* the snake chain's capstan law: :mod:`~tendon_id.calibration.law` (constrained least squares),
  :mod:`~tendon_id.calibration.problem` (the law's problem, built once),
  :mod:`~tendon_id.calibration.law_layout` (its parameter vector and feasible set) and
  :mod:`~tendon_id.calibration.encoder` (encoder quantisation in the posterior).
"""
