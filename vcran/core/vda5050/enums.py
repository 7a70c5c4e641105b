"""The enumerations of VDA 5050 2.x (chapter 6), as ``str`` enums whose values are the wire spellings.

VDA 5050 writes every enumeration in upper case without underscores (§6.1.3); the members here carry the
same names, so ``BlockingType.HARD.value == "HARD"``. One module for all of them: they are shared by the
order, state and factsheet messages and by the vehicle.
"""

from __future__ import annotations

import enum


class Version(enum.Enum):
    """The protocol versions vcran speaks. A vehicle's version decides what it stamps, sends and
    validates (docs/vda5050.md, "Versions"); 2.0.0 is what most deployed masters speak."""

    V2_0_0 = "2.0.0"
    V2_1_0 = "2.1.0"

    @property
    def major(self) -> str:
        """The topic level of §6.3: ``v2``."""
        return "v" + self.value.split(".", 1)[0]

    def at_least(self, other: Version) -> bool:
        """Whether this version has what ``other`` introduced."""
        return _RANK[self] >= _RANK[other]


_RANK = {v: i for i, v in enumerate(Version)}


class BlockingType(enum.Enum):
    """§6.12: NONE allows driving and other actions, SOFT other actions but not driving, HARD nothing."""

    NONE = "NONE"
    SOFT = "SOFT"
    HARD = "HARD"


class ActionStatus(enum.Enum):
    """§6.11. FINISHED and FAILED are final."""

    WAITING = "WAITING"
    INITIALIZING = "INITIALIZING"
    RUNNING = "RUNNING"
    PAUSED = "PAUSED"
    FINISHED = "FINISHED"
    FAILED = "FAILED"

    @property
    def final(self) -> bool:
        return self is ActionStatus.FINISHED or self is ActionStatus.FAILED


class ErrorLevel(enum.Enum):
    """§6.10.5: a WARNING resolves itself; a FATAL error needs a human."""

    WARNING = "WARNING"
    FATAL = "FATAL"


class InfoLevel(enum.Enum):
    DEBUG = "DEBUG"
    INFO = "INFO"


class OperatingMode(enum.Enum):
    """§6.10.6, Table 1."""

    AUTOMATIC = "AUTOMATIC"
    SEMIAUTOMATIC = "SEMIAUTOMATIC"
    MANUAL = "MANUAL"
    SERVICE = "SERVICE"
    TEACHIN = "TEACHIN"


class EStop(enum.Enum):
    AUTOACK = "AUTOACK"
    MANUAL = "MANUAL"
    REMOTE = "REMOTE"
    NONE = "NONE"


class ConnectionState(enum.Enum):
    """§6.14: CONNECTIONBROKEN is the broker's last will."""

    ONLINE = "ONLINE"
    OFFLINE = "OFFLINE"
    CONNECTIONBROKEN = "CONNECTIONBROKEN"


class MapStatus(enum.Enum):
    """§6.7.2 (2.1.0 only)."""

    ENABLED = "ENABLED"
    DISABLED = "DISABLED"


class OrientationType(enum.Enum):
    """Edge orientation reference (2.1.0 only); absent means TANGENTIAL."""

    GLOBAL = "GLOBAL"
    TANGENTIAL = "TANGENTIAL"


class CorridorRefPoint(enum.Enum):
    """§6.6.5 (2.1.0 only)."""

    KINEMATICCENTER = "KINEMATICCENTER"
    CONTOUR = "CONTOUR"


class ActionScope(enum.Enum):
    """Factsheet: where an action type may be used."""

    INSTANT = "INSTANT"
    NODE = "NODE"
    EDGE = "EDGE"


class AgvKinematic(enum.Enum):
    DIFF = "DIFF"
    OMNI = "OMNI"
    THREEWHEEL = "THREEWHEEL"


class AgvClass(enum.Enum):
    FORKLIFT = "FORKLIFT"
    CONVEYOR = "CONVEYOR"
    TUGGER = "TUGGER"
    CARRIER = "CARRIER"


class LocalizationType(enum.Enum):
    NATURAL = "NATURAL"
    REFLECTOR = "REFLECTOR"
    RFID = "RFID"
    DMC = "DMC"
    SPOT = "SPOT"
    GRID = "GRID"


class NavigationType(enum.Enum):
    PHYSICAL_LINE_GUIDED = "PHYSICAL_LINE_GUIDED"
    VIRTUAL_LINE_GUIDED = "VIRTUAL_LINE_GUIDED"
    AUTONOMOUS = "AUTONOMOUS"


class Support(enum.Enum):
    """Factsheet: how an optional parameter is supported."""

    SUPPORTED = "SUPPORTED"
    REQUIRED = "REQUIRED"


class ValueDataType(enum.Enum):
    BOOL = "BOOL"
    NUMBER = "NUMBER"
    INTEGER = "INTEGER"
    FLOAT = "FLOAT"
    STRING = "STRING"
    OBJECT = "OBJECT"
    ARRAY = "ARRAY"


class WheelType(enum.Enum):
    DRIVE = "DRIVE"
    CASTER = "CASTER"
    FIXED = "FIXED"
    MECANUM = "MECANUM"


class Topic(enum.Enum):
    """The six topics of §6.5; the value is the topic level and the schema's name."""

    ORDER = "order"
    INSTANT_ACTIONS = "instantActions"
    STATE = "state"
    VISUALIZATION = "visualization"
    CONNECTION = "connection"
    FACTSHEET = "factsheet"

