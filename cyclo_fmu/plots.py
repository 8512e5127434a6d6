"""Figures (matplotlib only here): each function draws one figure and writes it."""
from __future__ import annotations

from pathlib import Path



def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_stiffness(design, rated_torque, path) -> Path:
    """Twist over torque with the input locked: the hysteresis curve of a +-rated cycle and
    the catalogue's construction lines (lost motion at +-3 %, rigidity between 50 and 100 %)."""
    from model_core import stiffness as st
    plt = _plt()
    loop = st.hysteresis_loop(design, rated_torque, n=161)
    phi = loop["twist_rad"] * st.RAD_TO_ARCMIN
    fig, ax = plt.subplots(figsize=(7, 5))
    ax.plot(loop["torque_loading_Nm"], phi, label="torque rising")
    ax.plot(loop["torque_unloading_Nm"], phi, label="torque falling")
    T3 = st.LOST_MOTION_SHARE * rated_torque
    lm = st.twist(design, T3) * st.RAD_TO_ARCMIN
    ax.axvspan(-T3, T3, color="0.9", label=f"lost motion band (+-3 %): {2 * lm:.3g} arcmin")
    a, b = st.RIGIDITY_SHARES
    pa, pb = st.twist(design, [a * rated_torque, b * rated_torque]) * st.RAD_TO_ARCMIN
    ax.plot([a * rated_torque, b * rated_torque], [pa, pb], "k--", lw=0.8,
            label=f"rigidity {(b - a) * rated_torque / (pb - pa):.3g} N*m/arcmin")
    ax.set(xlabel="output torque / N*m", ylabel="twist of the output / arcmin",
           title="torsional behaviour, input locked (series model)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
