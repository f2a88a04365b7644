"""Benchmark B, ring release: a closed belt wrapped as a "stadium" around two circles (R = 0.1 m
at the belt axis, centre distance d = 0.1 pi m) is released from rest with no pulleys and no
gravity. Being stress-free straight, it must settle (with damping) to a circle of radius
L0 / (2 pi) = 0.2 m, its centroid fixed, its energy never increasing.

This case has no pulleys, so it is not a drive configuration (TOML) but a short script on
``jaxbelt.dynamics.simulate_free_belt``:

    python examples/ring_release.py [--out DIR] [--n-elements N] [--t-end T]

Reduced-size belt (EA = 1e4 N, EI = 1 N m^2, rhoA = 1 kg/m) so that it settles within 0.25 s;
mass-proportional damping set to critical for the final circle's slowest (n = 2) flexural mode.
"""

import argparse
import math
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import jaxbelt as jb  # noqa: E402

R, D = 0.1, 0.1 * math.pi  # circles of the stadium [m]
EA, EI, RHO_A = 1.0e4, 1.0, 1.0  # N, N m^2, kg/m


def stable_dt(L0: float, n: int) -> float:
    """Half the explicit (symplectic Euler) limit 2/omega_max. The highest mode of the cubic ANCF
    mesh with consistent mass is axial, omega_max ~ 12.6 c / h (c = sqrt(EA / rhoA), h = L0 / n;
    measured from the eigenvalues in tests/test_belt_dynamics.py); 13 c / h is used."""
    c, h = math.sqrt(EA / RHO_A), L0 / n
    return 0.5 * 2.0 / (13.0 * c / h)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/ring_release", help="output directory (default out/ring_release)")
    ap.add_argument("--n-elements", type=int, default=32)
    ap.add_argument("--t-end", type=float, default=0.25)
    args = ap.parse_args()

    n = args.n_elements
    path = jb.geometry.belt_path(jnp.asarray([[0.0, 0.0], [D, 0.0]]), jnp.asarray([R, R]), (1, 1))
    L0 = float(path.length)  # stress-free length = the stadium: no pre-stretch
    q0 = jb.geometry.place_belt(path, n, L0)
    params = jb.belt.BeltParams(
        EA=jnp.asarray(EA),
        EI=jnp.asarray(EI),
        axial_damping=jnp.asarray(0.0),
        bending_damping=jnp.asarray(0.0),
        mass_per_length=jnp.asarray(RHO_A),
        stress_free_length=jnp.asarray(L0),
    )
    R_final = L0 / (2 * math.pi)
    # critical damping of the n = 2 ring mode: omega_2 = sqrt(EI / (rhoA R^4)) * 2 * 3 / sqrt(5)
    omega2 = math.sqrt(EI / (RHO_A * R_final**4)) * 6.0 / math.sqrt(5.0)
    dt = stable_dt(L0, n)
    ts, states = jb.dynamics.simulate_free_belt(
        params, q0, jnp.zeros_like(q0), t_end=args.t_end, dt=dt, n_save=201, mass_damping=2.0 * omega2
    )
    T, U, Ed = (np.asarray(a) for a in jb.dynamics.free_belt_energies(params, states, dt))
    q = np.asarray(states.q)
    pos = q[:, :, 0, :]
    centroid = pos.mean(axis=1)  # nodes are equally spaced in material length
    radius = np.linalg.norm(pos - centroid[:, None, :], axis=2)
    r_end = radius[-1]
    # the scheme conserves its discrete energy Ed = T + U + (h/2) v.f (not T + U exactly);
    # Ed plus what damping removed stays constant
    E = Ed + np.asarray(states.dissipated)

    print(f"ring release: {n} elements, L0 = {L0:.6f} m, dt = {dt:.3g} s, t_end = {float(ts[-1]):.3g} s")
    print(f"final radius: mean {r_end.mean():.6f} m, spread {r_end.max() - r_end.min():.2e} m")
    print(f"L0 / (2 pi)  : {R_final:.6f} m   (relative difference {r_end.mean() / R_final - 1:+.2e})")
    print(f"centroid moved by {np.linalg.norm(centroid[-1] - centroid[0]):.2e} m")
    print(
        f"bending energy: start {U[0]:.4f} J (pi EI / R = {math.pi * EI / R:.4f}), "
        f"end {U[-1]:.4f} J (pi EI / {R_final:.3g} = {math.pi * EI / R_final:.4f})"
    )
    print(
        f"energy T + U never increases: {bool(np.all(np.diff(T + U) <= 1e-9 * (T + U)[0]))}; "
        f"discrete energy + dissipated stays at {E[0]:.4f} J within {np.ptp(E) / E[0]:.1e} (relative)"
    )

    fig = Figure(figsize=(11, 4.5), layout="constrained")
    ax, ax2 = fig.subplots(1, 2, width_ratios=[1.2, 1])
    L = L0 / n
    xi = np.linspace(0, 1, 8, endpoint=False)
    S = np.stack(
        [1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, L * (xi**3 - xi**2)], -1
    )

    def curve(qk):
        nxt = np.roll(np.arange(n), -1)
        pts = np.einsum("kc,ncd->nkd", S, np.stack([qk[:, 0], qk[:, 1], qk[nxt, 0], qk[nxt, 1]], 1)).reshape(-1, 2)
        return np.vstack([pts, pts[:1]])

    for k, style in ((0, "-"), (len(ts) // 20, "--"), (len(ts) // 8, "--"), (len(ts) - 1, "-")):
        c = curve(q[k])
        ax.plot(c[:, 0], c[:, 1], style, lw=1.6 if style == "-" else 0.9, label=f"t = {float(ts[k]):.3f} s")
    phi = np.linspace(0, 2 * np.pi, 200)
    ax.plot(
        centroid[-1, 0] + R_final * np.cos(phi),
        centroid[-1, 1] + R_final * np.sin(phi),
        "k:",
        lw=1,
        label=f"circle L0/(2 pi) = {R_final:.4f} m",
    )
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Ring release: belt centre line")
    ax.legend(fontsize="x-small", loc="upper right")
    ax.grid(True, alpha=0.3)
    ax2.plot(ts, U, label="elastic U")
    ax2.plot(ts, T, label="kinetic T")
    ax2.plot(ts, T + U, label="T + U")
    ax2.axhline(math.pi * EI / R_final, color="k", ls=":", lw=1, label="pi EI / (L0 / 2 pi)")
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel("energy [J]")
    ax2.set_title("Energies")
    ax2.legend(fontsize="x-small")
    ax2.grid(True, alpha=0.3)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "ring_release.png", dpi=120)
    print(f"wrote {out / 'ring_release.png'}")


if __name__ == "__main__":
    main()
