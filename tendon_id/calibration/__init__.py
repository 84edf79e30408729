"""Fitting a family's law to data, and sampling its posterior.

One package for the law fitting of the toolkit (:doc:`/guide/architecture`):

* what every family uses: :mod:`~tendon_id.calibration.posterior` (the posterior sampler:
  walkers, emcee, diagnostics), :mod:`~tendon_id.calibration.mcmc` (ArviZ's ESS and R-hat) and
  :mod:`~tendon_id.calibration.optimize` (the one place nlopt is called);
* the snake chain's capstan law: :mod:`~tendon_id.calibration.law` (constrained least squares),
  :mod:`~tendon_id.calibration.problem` (the law's problem, built once),
  :mod:`~tendon_id.calibration.law_layout` (its parameter vector and feasible set),
  :mod:`~tendon_id.calibration.encoder` (encoder quantisation in the posterior) and
  :mod:`~tendon_id.calibration.law_posterior` (its likelihood).

``tendon-id calibrate`` (fit, files, posterior) is :mod:`tendon_id.report.calibration`; the bench
passage's fit lives with its family, in :mod:`tendon_id.zoo.passage.fitting`.
"""
