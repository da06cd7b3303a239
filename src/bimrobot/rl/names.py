"""Names of the benchmark's algorithms hyperparameter profiles and reward-shaping metrics, importable without torch.

The command line lists them in ``--help``; importing :mod:`bimrobot.rl.algorithms` for that would load
PyTorch (about 5 s) on every ``bimrobot`` call. :mod:`bimrobot.rl.algorithms` checks that both lists
match its tables.
"""

ALGORITHM_NAMES = ("ppo", "maskable-ppo", "a2c", "dqn", "double-dqn", "dueling-dqn", "double-dueling-dqn")
PROFILE_NAMES = ("thesis", "fast")
SHAPING_METRICS = ("path", "manhattan")
