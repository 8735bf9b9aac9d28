"""Write ``direct_drive_measured.csv``: a recording of the direct-drive arm, made by the simulator,
in the form a user's own measurements take (one row per sample, SI units).

The arm of the direct-drive paper ([DirectDrivePaper] in docs/references.md) runs in open loop under
the paper's torques (31)-(32) for 6 s; the recording keeps what a controller logs at h = 2.5 ms:
16-bit encoder angles [rad] and the applied torques [N m] with uniform noise of +-0.5 N m.
Columns: ``t_s`` (time, uniformly spaced), ``q1_rad``, ``q2_rad``, ``tau1_Nm``, ``tau2_Nm``.

Run ``python studies/examples/make_measured_csv.py`` to write it again (same seed, same file);
``measured_direct_drive.toml`` beside it is the study that reads it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.experiments.excitation import RampedMultisine
from boundid.experiments.measurement import TorqueNoise
from boundid.experiments.simulation import measure, simulate_open_loop
from boundid.models import DirectDriveArm

DURATION_S = 6.0
PERIOD_S = 0.0025
SEED = 2024
CSV = Path(__file__).with_name("direct_drive_measured.csv")


def recording(seed: int = SEED) -> pd.DataFrame:
    """The simulated recording as the table a user would save (columns as in the module docstring)."""
    model = DirectDriveArm()
    traj = simulate_open_loop(model, RampedMultisine.direct_drive_paper(), DURATION_S, PERIOD_S)
    meas = measure(traj, 2 ** 16, TorqueNoise("uniform", 0.5), np.random.default_rng(seed))
    return pd.DataFrame({"t_s": meas.t, "q1_rad": meas.q[:, 0], "q2_rad": meas.q[:, 1],
                         "tau1_Nm": meas.tau[:, 0], "tau2_Nm": meas.tau[:, 1]})


def main(out: str | Path = CSV) -> Path:
    out = Path(out)
    recording().to_csv(out, index=False, float_format="%.10g")
    return out


if __name__ == "__main__":
    print(main(*sys.argv[1:]))
