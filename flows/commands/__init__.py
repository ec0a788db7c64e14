"""The commands of ``fleet-health``: one module per command, each with ``add_*`` (its
sub-parser) and its handler; :mod:`flows.commands.plumbing` holds what they share.

:mod:`flows.cli` mounts them (its ``COMMANDS``). A command that runs a Prefect flow imports
the flow inside its handler, after :func:`~flows.commands.plumbing.prefect_environment`: the
parser, ``--help`` and configuration errors never load prefect, mlflow or torch.
"""
