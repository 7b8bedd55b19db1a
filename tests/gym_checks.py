"""What every Gymnasium environment's tests ask of it, written once: registered in any import
order (a fresh process), and nothing Stable-Baselines3's checker would warn of."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def registered_entry_point(env_id: str, first: str = "piezotip") -> str:
    """The entry point ``gymnasium.spec(env_id)`` names in a fresh Python that imports ``first``
    (``piezotip`` or ``gymnasium``) before the other."""
    second = "gymnasium" if first == "piezotip" else "piezotip"
    code = f"import {first}, {second}, gymnasium; print(gymnasium.spec({env_id!r}).entry_point)"
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def stable_baselines3_warnings(env) -> list[str]:
    """What Stable-Baselines3's environment checker warns of ``env`` (unbounded or unnormalized
    spaces, ...: what its algorithms would trip on); ``env`` is closed after."""
    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, warn=True, skip_render_check=True)
    env.close()
    return [str(w.message) for w in caught if "stable_baselines3" in w.filename]
