"""Dataset recipes: a robot, its friction, its effects, its sensors and its protocols (one TOML file each)."""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from tendon_id.checks import check_choice, check_keys
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry
from tendon_id.robot_file import resolve_robot
from tendon_id.sim.actuation import Actuation
from tendon_id.sim.body import Body
from tendon_id.sim.effects import Effects
from tendon_id.sim.protocols import PAPER_FRAMES, PROTOCOL_NAMES, ProtocolSettings
from tendon_id.sim.sensors import Sensors
from tendon_id.sim.transmission import FrictionLaw

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _build(cls, section: str, d: Mapping | None):
    d = dict(d or {})
    known = {f.name for f in fields(cls)}
    check_keys(d, known, what=f"setting of [{section}]")
    try:
        return cls(**d)
    except TypeError as exc:  # wrong value types from TOML
        raise ConfigError(f"[{section}]: {exc}") from None


@dataclass(frozen=True)
class Recipe:
    """Everything the simulator needs to make one dataset (:doc:`/guide/simulator`).

    Attributes
    ----------
    name : str
    description : str
    seed : int
        Default seed; a ``simulate`` call may override it.
    sample_rate_hz : float
        Logging rate [Hz] (paper: 10 Hz).
    v_max_deg_s : float
        Peak joint speed of every move [deg/s] (paper: below 9 deg/s in 99 % of frames).
    session : {"continuous", "fresh"}
        ``"continuous"``: the logged trajectories are excerpts of one session, joined
        by unlogged moves, so each one starts in whatever stick/slip and lag state
        the robot was left in (as on a real robot).  ``"fresh"``: every trajectory
        starts from newly pretensioned tendons (forward slip).
    robot : RobotGeometry
    friction : FrictionLaw
        The truth friction law.
    effects : Effects
        Unmodelled effects on by default, with settings.
    actuation : Actuation
    sensors : Sensors
    protocols : mapping of str to ProtocolSettings
    body : Body
        Link and payload masses and the base's orientation against gravity: what only the closed
        loop's plant reads (:doc:`/guide/closed_loop`).
    """

    name: str
    description: str = ""
    seed: int = 0
    sample_rate_hz: float = 10.0
    v_max_deg_s: float = 8.0
    session: str = "continuous"
    robot: RobotGeometry = field(default_factory=RobotGeometry)
    friction: FrictionLaw = field(default_factory=FrictionLaw)
    effects: Effects = field(default_factory=Effects)
    actuation: Actuation = field(default_factory=Actuation)
    sensors: Sensors = field(default_factory=Sensors)
    protocols: Mapping[str, ProtocolSettings] = field(default_factory=dict)
    body: Body = field(default_factory=Body)

    def __post_init__(self) -> None:
        if not self.sample_rate_hz > 0:
            raise ConfigError("sample_rate_hz must be positive")
        if not 0 < self.v_max_deg_s <= 9.0:
            raise ConfigError("v_max_deg_s must lie in (0, 9] deg/s: the paper's data is quasi-static")
        if self.session not in ("continuous", "fresh"):
            raise ConfigError(f"session must be 'continuous' or 'fresh', got {self.session!r}")

    @property
    def dt(self) -> float:
        """Sample period [s]."""
        return 1.0 / self.sample_rate_hz

    def protocol(self, name: str) -> ProtocolSettings:
        """Settings of protocol ``name`` (the paper's frame count when the recipe is silent)."""
        if name not in PROTOCOL_NAMES:
            check_choice("protocol", name, PROTOCOL_NAMES)
        if name in self.protocols:
            return self.protocols[name]
        return ProtocolSettings(frames=PAPER_FRAMES[name])

    def _tendons_agree(self) -> Recipe:
        """This recipe, once its friction law has one (A_i, B_i) per tendon of the robot's sets."""
        if len(self.friction.A) != self.robot.n_tendons:
            raise ConfigError(
                f"[friction] A and B need one value per tendon: the robot has {self.robot.n_tendons} per set, "
                f"A has {len(self.friction.A)}"
            )
        return self

    def robot_for(self, protocol: str) -> RobotGeometry:
        """The robot a protocol runs on: the single-passage rig has 2 modules and one guide (its first two sets)."""
        if protocol != "single-passage":
            return self.robot
        az = self.robot.azimuths
        return replace(self.robot, n_modules=2, azimuths=None if az is None else az[:2] if len(az) > 1 else az)

    def to_dict(self) -> dict:
        """Plain-JSON form (also what the dataset cache key hashes)."""
        return {
            "name": self.name,
            "description": self.description,
            "seed": self.seed,
            "sample_rate_hz": self.sample_rate_hz,
            "v_max_deg_s": self.v_max_deg_s,
            "session": self.session,
            "robot": self.robot.to_dict(),
            "friction": {"A": list(self.friction.A), "B": list(self.friction.B)},
            "effects": self.effects.to_dict(),
            "actuation": asdict(self.actuation),
            "sensors": asdict(self.sensors),
            "protocols": {k: asdict(v) for k, v in self.protocols.items()},
            # Only where set: the open-loop data do not read it, so recipes without it keep their cache keys.
            **({"body": asdict(self.body)} if self.body != Body() else {}),
        }

    def fingerprint(self) -> str:
        """Short hash of the recipe's content."""
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()[:16]

    @classmethod
    def from_dict(cls, d: Mapping, *, source: str = "<recipe>") -> Recipe:
        """Build a recipe from the TOML layout (see ``datasets/*.toml``)."""
        d = dict(d)
        known = {
            "name",
            "description",
            "seed",
            "sample_rate_hz",
            "v_max_deg_s",
            "session",
            "robot",
            "friction",
            "effects",
            "actuation",
            "sensors",
            "protocols",
            "body",
            "card",
        }
        check_keys(d, known, what="section", where=str(source))
        if "name" not in d:
            raise ConfigError(f"{source}: a recipe needs a name")
        try:
            eff = dict(d.get("effects", {}))
            enabled = eff.pop("enabled", [])
            effects = Effects(enabled=tuple(enabled), params=eff)
            protocols = {}
            for pname, pset in dict(d.get("protocols", {})).items():
                if pname not in PROTOCOL_NAMES:
                    check_choice("protocol", pname, PROTOCOL_NAMES)
                protocols[pname] = ProtocolSettings.from_dict(pname, dict(pset))
            return cls(
                name=str(d["name"]),
                description=str(d.get("description", "")),
                seed=int(d.get("seed", 0)),
                sample_rate_hz=float(d.get("sample_rate_hz", 10.0)),
                v_max_deg_s=float(d.get("v_max_deg_s", 8.0)),
                session=str(d.get("session", "continuous")),
                robot=RobotGeometry.from_dict(resolve_robot(d.get("robot"), base=_folder(source), where="[robot]")),
                friction=_build(FrictionLaw, "friction", d.get("friction")),
                effects=effects,
                actuation=_build(Actuation, "actuation", d.get("actuation")),
                sensors=_build(Sensors, "sensors", d.get("sensors")),
                protocols=protocols,
                body=_build(Body, "body", d.get("body")),
            )._tendons_agree()
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> Recipe:
        """Read a recipe file."""
        path = Path(path)
        try:
            with path.open("rb") as fh:
                data = tomllib.load(fh)
        except FileNotFoundError:
            raise ConfigError(f"{path}: no such recipe file") from None
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"{path}: not valid TOML ({exc})") from None
        return cls.from_dict(data, source=str(path))


def _folder(source: str) -> Path | None:
    """The folder of the recipe file ``source`` (a robot file's relative path is read from there)."""
    p = Path(source)
    return p.parent if p.suffix == ".toml" else None
