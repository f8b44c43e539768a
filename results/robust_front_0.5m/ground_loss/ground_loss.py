"""The ground-loss tables a team building the recommended plane would load into the EDGES pipeline: the
600 m^2 answer (``../answer-600.json``) and ``sawtooth-20-16`` on each soil of the ``soil`` set at the
default model (surface engine, 0.5 m, 55-97 MHz every 1 MHz; beams from the cache, solved if missing),
one two-column table per plane and soil (``groundplane.loss.write_loss_table``: MHz, fraction; the
format ``groundplane loss -o`` writes), a figure of all of them and a markdown summary whose every
verdict is a condition on its numbers.

    .venv/bin/python results/robust_front_0.5m/ground_loss/ground_loss.py

The loss is the calibration term: EDGES divides its spectra by 1 - L, so what matters beside its size
is how much it changes with the soil (the spread, which a team that does not know its soil carries as
an error) and how it bends across the band (a smooth loss is absorbed by the foreground fit).
"""
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(ROOT))
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]  # the `soil` set: MRO, the corners
LIMIT = 0.005  # the search's --max-loss
TERMS = 5  # a LinLog-like smooth fit in log frequency: what of the loss's shape a foreground fit would absorb
T_SKY_K = 2000.0  # the foreground a relative error multiplies (~2000 K in the band): 1 ppm is 2 mK


def bend(freqs: np.ndarray, loss: np.ndarray) -> float:
    """The rms residual of the correction factor 1 - L after a 5-term polynomial in log frequency: the
    part of the loss's spectral shape a smooth foreground model would not absorb (fraction)."""
    x = np.log(freqs / freqs.mean())
    y = 1.0 - loss
    fit = np.polynomial.polynomial.polyval(x, np.polynomial.polynomial.polyfit(x, y, TERMS - 1))
    return float(np.sqrt(np.mean((y - fit) ** 2)))


def main() -> None:
    """Write the tables, the figure and the summary."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from groundplane.loss import spread_across, write_loss_table
    from groundplane.shapes import PRESETS, from_file
    from solvers.api import solve_soils

    planes = {"answer-600": from_file(ROOT / "results/robust_front_0.5m/answer-600.json"),
              "sawtooth-20-16": PRESETS["sawtooth-20-16"]}
    command = f".venv/bin/python {Path(__file__).relative_to(ROOT)}"
    summary = [f"<!-- {command} -->", "# Ground loss of the plane to build and of `sawtooth-20-16`\n",
               "Default model (surface engine, 0.5 m, 55-97 MHz every 1 MHz), each soil of the `soil` set. "
               "Tables: `<plane>_eps<eps_r>_sig<sigma>.txt` here (MHz, loss as a fraction; the format "
               "`groundplane loss -o` writes). *Bend*: rms of 1 - L about a 5-term polynomial in log frequency, "
               "the part of the correction a smooth foreground fit would not absorb.\n",
               "| plane | soil (eps_r, S/m) | loss at 55 / 76 / 97 MHz (%) | largest (%) | within 0.5 %? | bend (ppm) |",
               "|---|---|---|---|---|---|"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    spreads, wrong = {}, {}
    for (name, plane), ax in zip(planes.items(), axes):
        beams = solve_soils(plane, SOILS, mesh=0.5, freqs="55:97:1", workers=2)
        losses = []
        for (eps_r, sigma), beam in zip(SOILS, beams):
            f, loss = beam.freqs_mhz, beam.ground_loss()
            losses.append(loss)
            write_loss_table(HERE / f"{name}_eps{eps_r:g}_sig{sigma:g}.txt", beam, command)
            at = [float(loss[np.argmin(np.abs(f - x))]) for x in (55, 76, 97)]
            top = float(loss.max())
            summary.append(f"| {name} | {eps_r:g}, {sigma:g} | {' / '.join(f'{100 * a:.3f}' for a in at)} | "
                           f"{100 * top:.3f} | {'yes' if top <= LIMIT else 'no'} | {1e6 * bend(f, loss):.1f} |")
            ax.plot(f, 100 * loss, label=f"eps_r {eps_r:g}, {sigma:g} S/m")
        spreads[name] = spread_across(losses)
        # corrected with MRO's loss (the nominal soil) while the ground is another member: what is left unfit
        wrong[name] = max((bend(f, x - losses[0]), SOILS[i]) for i, x in enumerate(losses) if i)
        ax.axhline(100 * LIMIT, color="0.5", ls="--", lw=0.8, label="the search's limit (0.5 %)")
        ax.set_title(f"{name} ({plane.metal_area:.0f} m$^2$)")
        ax.set_xlabel("frequency (MHz)")
    axes[0].set_ylabel("ground loss (%)")
    axes[0].set_ylim(0, None)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(HERE / "ground_loss.png", dpi=120)
    summary += ["", "*Corrected with MRO's loss on another soil*: the bend of that soil's loss minus MRO's, the structure "
                f"left in a spectrum corrected with the nominal soil's table (x {T_SKY_K:g} K of foreground).", "",
                "| plane | largest spread across the soils (%) | at (MHz) | corrected with MRO's loss on another soil: "
                "largest bend (ppm) | its soil | x 2000 K (mK) |", "|---|---|---|---|---|---|"]
    for name, sp in spreads.items():
        i = int(np.argmax(sp))
        w, soil = wrong[name]
        summary.append(f"| {name} | {100 * sp[i]:.3f} | {beams[0].freqs_mhz[i]:g} | {1e6 * w:.2f} | "
                       f"{soil[0]:g}, {soil[1]:g} | {1e3 * T_SKY_K * w:.1f} |")
    a, b = (float(spreads[k].max()) for k in planes)
    summary += ["", (f"The 600 m^2 answer's loss moves {a / b:.2f}x as much with the soil as `sawtooth-20-16`'s "
                     f"({100 * a:.3f} against {100 * b:.3f} points): " +
                     ("a larger calibration term to carry." if a > b else "no larger a calibration term to carry.")),
                "", (lambda wa, wb: f"Corrected with MRO's table on the worst other soil, the 600 m^2 answer leaves "
                     f"{1e3 * T_SKY_K * wa:.1f} mK of structure the fit cannot absorb against `sawtooth-20-16`'s "
                     f"{1e3 * T_SKY_K * wb:.1f}: " + ("less" if wa < wb else "more") + " of its soil dependence is "
                     "spectral structure.")(*(wrong[k][0] for k in planes)),
                "", "![ground loss](ground_loss.png)"]
    (HERE / "README.md").write_text("\n".join(summary) + "\n")
    print("\n".join(summary))


if __name__ == "__main__":
    main()
