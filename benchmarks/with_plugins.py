"""The ``femupdate`` command line with the comparison optimizers registered (de, ga, scipy-lsq).

    python benchmarks/with_plugins.py bench bridge --model viscous --snr 0 \\
        --method multistart-lm,ab,cmaes,scipy-lsq

runs the product's methods side by side with the peer baselines in one run.
"""

from __future__ import annotations

from plugins import register_optimizers

from femupdate.cli import main

if __name__ == "__main__":
    register_optimizers()
    main()
