"""Dataset recipes (``datasets/*.toml``) and a cache of the recordings they build.

``tendon_id.datasets.load("snake12-elastic", protocol="posterior-3")`` simulates
the recipe's protocol once and caches the Parquet file; later calls read it
back.  The cache lives in ``$TENDON_ID_CACHE`` or ``~/.cache/tendon-id``.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from tendon_id import __version__
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.robot_file import bundled_dir
from tendon_id.sim import Recipe, parse_effect_names, simulate

#: The recipe that ``tendon-id demo``, ``tendon-id simulate`` and :func:`load` use when none is named: elastic
#: tendons and sensors as built (its card says why it is the default; the paper's benchmarks keep ``snake12-paper``).
DEFAULT_RECIPE = "snake12-elastic"
#: Part of every cache key: bump it when the simulator writes different content for the same recipe
#: (2: the metadata states the recipe's ``session``; 3: and the effects' ``options`` that are on), so a
#: stale cached recording is never read back.
SIMULATION_REVISION = 3


def recipe_dir() -> Path:
    """Folder of the bundled recipes: inside an installed wheel, else the checkout's ``datasets/``."""
    return bundled_dir()


def names() -> list[str]:
    """Names of the bundled recipes."""
    return sorted(p.stem for p in recipe_dir().glob("*.toml"))


def load_recipe(name_or_path: str | os.PathLike | Recipe) -> Recipe:
    """A bundled recipe by name, or a recipe file by path (a :class:`Recipe` is returned as it is).

    Raises
    ------
    ConfigError
        If there is no such recipe, naming the known ones.
    """
    if isinstance(name_or_path, Recipe):
        return name_or_path
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return Recipe.from_toml(p)
    candidate = recipe_dir() / f"{name_or_path}.toml"
    if not candidate.is_file():
        raise ConfigError(f"no recipe named {str(name_or_path)!r}; bundled recipes: {', '.join(names()) or 'none'}")
    return Recipe.from_toml(candidate)


def mapping_names() -> list[str]:
    """Names of the bundled mapping files (``datasets/mappings/*.toml``)."""
    return sorted(p.stem for p in (recipe_dir() / "mappings").glob("*.toml"))


def mapping_path(name_or_path: str | os.PathLike) -> Path:
    """A mapping file by path, or a bundled one by name (e.g. ``mis-tool-characterization``).

    Raises
    ------
    ConfigError
        If it is neither, naming the bundled ones.
    """
    p = Path(name_or_path)
    if p.is_file():
        return p
    bundled = recipe_dir() / "mappings" / f"{name_or_path}.toml"
    if bundled.is_file():
        return bundled
    raise ConfigError(
        f"{str(name_or_path)!r}: no such file, nor a bundled mapping ({', '.join(mapping_names()) or 'none'})",
        param="mapping",
    )


def cache_dir() -> Path:
    """Where built datasets are cached (``$TENDON_ID_CACHE`` or ``~/.cache/tendon-id``)."""
    return Path(os.environ.get("TENDON_ID_CACHE") or Path.home() / ".cache" / "tendon-id")


def load(
    name: str | os.PathLike = DEFAULT_RECIPE,
    protocol: str = "posterior-3",
    *,
    seed: int | None = None,
    effects: str | list[str] | None = None,
    frames: int | None = None,
    cache: bool = True,
    progress: bool | None = None,
) -> Recording:
    """Build (or read from the cache) one protocol of a recipe.

    Parameters
    ----------
    name : str or path
        Bundled recipe name or a recipe file.
    protocol : str
        Protocol to simulate.
    seed, effects, frames :
        Overrides, as for :func:`tendon_id.sim.simulate`.
    cache : bool
        Read and write the on-disk cache.
    progress : bool, optional
        Progress bar (default: on a terminal).

    Returns
    -------
    Recording
    """
    recipe = load_recipe(name)
    if effects is not None:
        effects = list(parse_effect_names(effects)) if isinstance(effects, str) else list(effects)
    key = json.dumps(
        {
            "recipe": recipe.to_dict(),
            "protocol": protocol,
            "seed": seed,
            "effects": effects,
            "frames": frames,
            "version": __version__,
            "revision": SIMULATION_REVISION,
        },
        sort_keys=True,
    )
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    path = cache_dir() / f"{recipe.name}-{protocol}-{digest}.parquet"
    if cache and path.is_file():
        return Recording.read(path)
    rec = simulate(recipe, protocol, seed=seed, effects=effects, frames=frames, progress=progress).recording
    if cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        rec.write(path)
    return rec
