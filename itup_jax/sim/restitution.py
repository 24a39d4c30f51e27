"""The restitution MuJoCo delivers, measured by a drop, and the damping ratio that delivers a wanted one.

A soft contact in MuJoCo is a damped spring (solref = time constant, damping ratio zeta). The textbook
spring-damper bounces with e = exp(-pi zeta / sqrt(1 - zeta^2)) if it lets go when the penetration
returns to zero. MuJoCo's contact lets go when its force returns to zero, earlier, while the spring is
still compressed and the damper pulls: the body leaves faster than the formula says (at zeta for
e = 0.4 it delivers about 0.45-0.49), and a critically damped contact still bounces (about 0.1-0.2).
On top of that the integrator's step and the impedance (solimp) shift it.

So the scenes do not invert the formula: `calibrated_dampratio` measures what MuJoCo delivers. It drops a
free capsule flat onto a plane with the tool-target contact's parameters (condim 3, MuJoCo's default
solimp, the scene's integrator, cone and step), reads the rebound speed over the impact speed at a
table of damping ratios, and interpolates the one whose delivered e equals the wanted one. `delivered_restitution`
is the same drop for any solref: the test of the calibration and of the scenes' contacts.

    zeta = calibrated_dampratio(0.4, timeconst=0.005, timestep=0.0005)
    delivered_restitution((0.005, zeta), timestep=0.0005)   # -> 0.40 (within 0.01)

A table costs 0.05-0.2 s (80 drops; longer for the long contacts of sweep and reach), and a run with
randomised contact durations asks several. Each process keeps its tables in memory; `keep_tables(folder)`
also keeps them on disk between processes (the command line does, next to its task cache), keyed by
MuJoCo's version, this module's source, the time constant and the step, so a stale table is never read.
"""

from __future__ import annotations

import functools
import hashlib
import io
import math
import os
from pathlib import Path

import mujoco
import numpy as np

from itup_jax.atomic import atomic_write

#: m/s, the drop's impact speed (the strikes meet their targets at 0.3-1.5 m/s)
DROP_SPEED = 1.0
#: damping ratios the calibration searches between: nearly undamped to well over-damped
DAMPRATIO_RANGE = (0.02, 3.0)


@functools.lru_cache(maxsize=8)
def _drop_model(timestep: float) -> mujoco.MjModel:
    """A free capsule (0.3 m, radius 1 cm, 0.3 kg) lying flat just above a plane, no gravity: it meets
    the plane at the speed it is given. The pair has the tool-target contact's friction and condim."""
    xml = f"""
<mujoco>
  <option timestep="{timestep!r}" integrator="implicitfast" cone="elliptic" impratio="10" gravity="0 0 0"/>
  <worldbody>
    <geom name="plane" type="plane" size="1 1 0.1" contype="0" conaffinity="0"/>
    <body name="rod" pos="0 0 0.0105">
      <freejoint/>
      <geom name="rod" type="capsule" size="0.01" fromto="-0.15 0 0 0.15 0 0" mass="0.3"
            contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <contact>
    <pair name="hit" geom1="rod" geom2="plane" condim="3" friction="0.5 0.5 0.005 0.0001 0.0001"/>
  </contact>
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def delivered_restitution(solref, timestep: float, speed: float = DROP_SPEED) -> float:
    """The restitution (-) a contact with MuJoCo `solref` (timeconst s, dampratio) delivers at step
    `timestep` (s): a rod dropped flat onto a plane at `speed` m/s, rebound speed over impact speed,
    read once the contact has let go (or after 40 time constants if it never does)."""
    m = _drop_model(float(timestep))
    m.pair_solref[0] = solref
    d = mujoco.MjData(m)
    d.qvel[2] = -speed
    touched = False
    for _ in range(int(40 * max(float(solref[0]), timestep) / timestep) + 10):
        mujoco.mj_step(m, d)
        if d.ncon and d.efc_force.size and np.any(d.efc_force != 0):
            touched = True
        elif touched:
            break
    return max(float(d.qvel[2]), 0.0) / speed


#: damping ratios at which `delivered_table` drops the rod (geometric, DAMPRATIO_RANGE)
TABLE_DAMPRATIOS = np.geomspace(*DAMPRATIO_RANGE, 80)


#: Folder where `delivered_table` keeps its tables between processes (None: in memory only).
_table_folder: Path | None = None


def keep_tables(folder: str | os.PathLike | None) -> None:
    """Keep `delivered_table`'s tables in `folder` between processes (made when the first is written), or
    only in memory with None. An entry that cannot be read is measured again and rewritten; a folder
    that cannot be written leaves the tables in memory."""
    global _table_folder
    _table_folder = None if folder is None else Path(folder)


def tables_folder() -> Path | None:
    """The folder `keep_tables` named, or None when the tables are kept only in memory."""
    return _table_folder


def _table_key(timeconst: float, timestep: float) -> str:
    """The file name of a table: SHA-256 of MuJoCo's version, this module's source, the damping ratios,
    the time constant and the step."""
    h = hashlib.sha256()
    h.update(f"mujoco {mujoco.__version__} timeconst {timeconst!r} timestep {timestep!r}".encode())
    h.update(Path(__file__).read_bytes())
    h.update(TABLE_DAMPRATIOS.tobytes())
    return h.hexdigest() + ".npy"


@functools.lru_cache(maxsize=512)
def delivered_table(timeconst: float, timestep: float) -> tuple[np.ndarray, np.ndarray]:
    """(damping ratios [K], delivered restitution [K], non-increasing) of a contact with time constant
    `timeconst` (s) at step `timestep` (s): K drops of `delivered_restitution`, 0.05-0.2 s, or read
    from the folder `keep_tables` names, bit for bit the same."""
    entry = None if _table_folder is None else _table_folder / _table_key(float(timeconst), float(timestep))
    if entry is not None:
        try:
            e = np.load(entry, allow_pickle=False)
            if e.shape == TABLE_DAMPRATIOS.shape and e.dtype == np.float64:
                return TABLE_DAMPRATIOS, e
        except (OSError, ValueError):  # missing, truncated or foreign: measured again
            pass
    e = np.minimum.accumulate(np.array([delivered_restitution((timeconst, z), timestep) for z in TABLE_DAMPRATIOS]))
    if entry is not None:
        buf = io.BytesIO()
        np.save(buf, e)
        try:
            entry.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(str(entry), buf.getvalue())
        except OSError:
            pass
    return TABLE_DAMPRATIOS, e


def calibrated_dampratio(restitution: float, timeconst: float, timestep: float) -> float:
    """The damping ratio (-) at which a contact of time constant `timeconst` (s) delivers
    `restitution` (-) at step `timestep` (s) in MuJoCo's drop (`delivered_restitution`): interpolated
    in `delivered_table` (within 0.01 of the wanted e on the tested range, `tests/test_restitution.py`),
    clipped to DAMPRATIO_RANGE where the wanted e lies beyond what the range delivers. One table per
    (time constant, step), cached: pass time constants rounded (`sim.scene.restitution_solref` rounds them
    to 0.1 ms) so that a randomised dataset asks a few dozen tables, not one per rollout."""
    zeta, e = delivered_table(float(timeconst), float(timestep))
    # np.interp wants increasing x: the table's e falls with zeta
    return float(np.interp(float(restitution), e[::-1], zeta[::-1]))


def textbook_dampratio(restitution: float) -> float:
    """zeta = -ln e / sqrt(pi^2 + ln^2 e): the spring-damper that lets go at zero penetration."""
    e = min(max(float(restitution), 1e-3), 0.999)
    return -math.log(e) / math.sqrt(math.pi**2 + math.log(e) ** 2)
