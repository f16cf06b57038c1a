"""Run repeated sorting trials into one run log, as in the paper's experiments.

The command (``mearm experiment``, ``python -m mearm.experiment``) is
:mod:`~mearm.experiment.commandline`; the rooms it uses:

- :mod:`~mearm.experiment.trials`: each trial's seed, config and layout, and running it;
- :mod:`~mearm.experiment.pool`: where trials run, and worker processes on this machine;
- :mod:`~mearm.experiment.cluster`: trials on a Dask cluster (``--scheduler``);
- :mod:`~mearm.experiment.ordered_log`: workers' records appended in trial order;
- :mod:`~mearm.experiment.resume`: continuing a log where it stopped.
"""

from mearm.experiment.cluster import CLUSTER_EXTRA, CONNECT_TIMEOUT_S, dask_cluster
from mearm.experiment.commandline import NEEDS_TERMINAL, main, terminal_prompt
from mearm.experiment.errors import TrialFailed
from mearm.experiment.ordered_log import (
    AHEAD_PER_WORKER,
    open_workers,
    run_trials_parallel,
)
from mearm.experiment.ordered_log import (
    _append_in_order as _append_in_order,  # for the tests of the ordering
)
from mearm.experiment.pool import WorkerProcess, Workers, process_pool
from mearm.experiment.resume import Resume, ready_to_append, resume_point
from mearm.experiment.trials import (
    PER_CLASS,
    Recording,
    TrialPlan,
    TrialResult,
    plan_trial,
    run_trial,
    run_trials,
    trial_config,
    trial_seed,
)

__all__ = [
    "AHEAD_PER_WORKER",
    "CLUSTER_EXTRA",
    "CONNECT_TIMEOUT_S",
    "NEEDS_TERMINAL",
    "PER_CLASS",
    "Recording",
    "Resume",
    "TrialFailed",
    "TrialPlan",
    "TrialResult",
    "WorkerProcess",
    "Workers",
    "dask_cluster",
    "main",
    "open_workers",
    "plan_trial",
    "process_pool",
    "ready_to_append",
    "resume_point",
    "run_trial",
    "run_trials",
    "run_trials_parallel",
    "terminal_prompt",
    "trial_config",
    "trial_seed",
]
