"""Writing: recording one fit, or a batch, as a complete run and a model version.

``submission``   what is submitted for recording (FitSubmission), its key and data hash
``run_content``  a recorded fit's tags, params, metrics, drift.json and description
``artifacts``    the signature bundle: JSON + safetensors + manifest, verified on read
``model_files``  the pyfunc model of a fit (logged model or the run's model/)
``plots``        residual/ACF, tier fits, zeta trend (matplotlib, Agg)
``runs``         logging one fit as a complete run, in few round trips
``recording``    recording fits idempotently (runs, versions, alias), one or a batch
``at_once``      a new candidate's artifacts, then its run, version and alias in one transaction
``group``        a group's fits together (one transaction), each asset on its own
``watermarks``   per-asset watermark on the registered model, read and committed (or a group's)
"""
