"""The first transverse frequency of the Meloland deck read off the records, without a model.

    python examples/meloland/spectral_ratio.py [--data ../shared/data/cesmd_meloland]

For each event, the H1 estimate of the transfer function from the footing of the centre column
(channel 2, transverse) to the middle of the deck (channel 7, transverse), |S_xy / S_xx| by
Welch's method over 10.24 s segments, and the frequency of its peak between 1 and 10 Hz: the
reference the updated model's first frequency is compared with. Both channels come from one
recorder in both events.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import signal

from femupdate.data.network import read_network_records

HERE = Path(__file__).resolve().parent
EVENTS = {"2010 El Mayor-Cucapah": "calexico2010_ce01336.zip",
          "1979 Imperial Valley": "imperialvalley1979_ce01336.zip"}
INPUT, DECK = 2, 7
SEGMENT_S = 10.24


def peak_frequency(base: np.ndarray, deck: np.ndarray, rate: float,
                   band: tuple[float, float] = (1.0, 10.0)) -> tuple[float, float]:
    """Frequency [Hz] and height of the peak of |H1| = |S_xy / S_xx| within ``band``.

    Parameters
    ----------
    base, deck : numpy.ndarray
        Input and response accelerations at one rate (cut to the shorter).
    rate : float
        Sampling rate [Hz].
    band : tuple of float
        Frequencies searched [Hz].

    Returns
    -------
    tuple of float
        The peak's frequency and the gain there.
    """
    n = min(base.size, deck.size)
    nperseg = round(SEGMENT_S * rate)
    f, s_xy = signal.csd(base[:n], deck[:n], fs=rate, nperseg=nperseg)
    _, s_xx = signal.welch(base[:n], fs=rate, nperseg=nperseg)
    gain = np.abs(s_xy / s_xx)
    inside = (f >= band[0]) & (f <= band[1])
    i = int(np.argmax(gain[inside]))
    return float(f[inside][i]), float(gain[inside][i])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path,
                        default=HERE.parents[2] / "shared" / "data" / "cesmd_meloland")
    args = parser.parse_args()
    for event, archive in EVENTS.items():
        base, deck = read_network_records(args.data / archive, channels=[INPUT, DECK])
        f, gain = peak_frequency(base.acceleration, deck.acceleration, base.rate)
        print(f"{event}: peak of |H| (ch {DECK} / ch {INPUT}) at {f:.2f} Hz "
              f"(gain {gain:.1f}; resolution {1 / SEGMENT_S:.3f} Hz)")


if __name__ == "__main__":
    main()
