"""The store: where the registry lives and how it talks to MLflow.

``naming``          experiment, registered-model and tag names (asset ids validated first)
``tracking_store``  tracking URIs, SQLite WAL and PostgreSQL set-up, per-asset locks
``retry``           "database is locked" retries, and which store failures are passing
``locks``           exclusive file and PostgreSQL advisory locks
``boundary``        MLflow's errors leave the registry as the registry's
``backend``         the MLflow client bound to one store, and the shared look-ups
``model_headers``   registered models' tags and aliases, read without their versions
``sql_writes``      a recorded fit in one transaction of MLflow's SQL stores; one-query look-ups
``probe``           whether the store can be read and written (``fleet-health check``)
"""
