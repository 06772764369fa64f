"""Figures of the arch eigenproblem: the characteristic function (paper Fig. 4) and the
first mode shapes (paper Fig. 5)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from beamsim.modes import ArchModes, characteristic_determinant


def _title(modes: ArchModes) -> str:
    return rf"{modes.bc} arch, $\alpha = h/R = {modes.alpha:g}$, $\beta = {modes.beta:g}$ rad"


def plot_determinant(modes: ArchModes, path: str, n_points: int = 1500) -> None:
    """Scaled characteristic function D(lam) with the computed eigenvalues marked (Fig. 4).

    lam is on a log axis so that all roots are visible; D is shown as ``asinh(D / s)``
    (s = median |D|) so its sign changes stay visible over many decades.
    """
    lam = np.geomspace(modes.lam[0] / 4.0, modes.lam[-1] * 1.3, n_points)
    d = characteristic_determinant(lam, modes.alpha, modes.beta, modes.bc)
    s = np.median(np.abs(d)) or 1.0
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    ax.plot(lam, np.arcsinh(d / s), lw=1.2, color="C0", label="scaled characteristic function")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.plot(modes.lam, np.zeros_like(modes.lam), "o", color="C3", label="eigenvalues")
    for n, x in enumerate(modes.lam, start=1):
        ax.annotate(rf"$\lambda_{n}$={x:.4g}", (x, 0), textcoords="offset points",
                    xytext=(3, 8 if n % 2 else -14), fontsize=8)
    ax.set_xscale("log")
    ax.set_xlabel(r"$\lambda = \omega^2 \rho R^2 / E$ (log scale)")
    ax.set_ylabel(r"asinh$(D(\lambda)/s)$")
    ax.set_title("Characteristic function, " + _title(modes), fontsize=10)
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def plot_mode_shapes(modes: ArchModes, path: str, n_show: int = 3) -> None:
    """Radial W_n and tangential U_n of the first ``n_show`` modes, and the deformed arch (Fig. 5)."""
    n_show = min(n_show, modes.n_modes)
    th = np.linspace(0.0, modes.beta, 301)
    w, u = modes.W(th)[:n_show], modes.U(th)[:n_show]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for n in range(n_show):
        ratio = modes.frequency_ratios[n]
        axes[0].plot(th, w[n], color=f"C{n}", label=rf"mode {n + 1}, $f_{n + 1}/f_1$ = {ratio:.3f}")
        axes[1].plot(th, u[n], color=f"C{n}")
        amp = 0.12 * modes.beta / np.abs(np.concatenate([w[n], u[n]])).max()
        r = 1.0 + amp * w[n]  # radius scaled by R = 1; w radial, u tangential
        phi = th + amp * u[n]
        axes[2].plot(r * np.sin(phi), r * np.cos(phi), color=f"C{n}")
    axes[2].plot(np.sin(th), np.cos(th), color="0.3", lw=2, ls="--", label="undeformed")
    axes[0].set_title(r"radial $W_n(\theta)$")
    axes[1].set_title(r"tangential $U_n(\theta)$")
    axes[2].set_title("deformed arch (exaggerated)")
    for ax in axes[:2]:
        clamped = modes.bc.startswith("clamped")
        ax.set_xlabel(r"$\theta$ [rad] (clamped end at 0)" if clamped else r"$\theta$ [rad]")
        ax.axhline(0, color="0.6", lw=0.6)
    axes[2].set_aspect("equal")
    axes[2].set_xlabel("x / R")
    axes[2].set_ylabel("y / R")
    axes[0].legend(fontsize=8)
    axes[2].legend(fontsize=8)
    fig.suptitle("Mass-normalised mode shapes, " + _title(modes), fontsize=10)
    fig.savefig(path, dpi=130)
    plt.close(fig)
