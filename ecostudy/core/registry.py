"""Named kinds, registered rather than chosen by if/elif: DAS methods, network strategies,
closed-loop controllers, study kinds.

A :class:`Registry` maps a name to an entry (a builder or a runner) with an optional option schema
(a pydantic model, ``extra="forbid"``, so an option given to the wrong kind is refused by name)
and a one-line description. An unknown name is refused with the list of known ones.
"""
from dataclasses import dataclass
from typing import Any, Callable, Generic, Iterable, Iterator, Optional, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class Spec(Generic[T]):
    """A registered kind: its name, its entry, its option schema (or None), what it is, and the
    names of the shared options it reads (``uses``: any other option given to it is refused)."""

    name: str
    entry: T
    schema: Optional[type] = None
    doc: str = ""
    uses: frozenset[str] = frozenset()


class Registry(Generic[T]):
    """Kinds of one family (``what``: "DAS method", "strategy", ...), in registration order."""

    def __init__(self, what: str) -> None:
        self.what = what
        self._specs: dict[str, Spec[T]] = {}

    def register(self, name: str, entry: T, schema: Optional[type] = None, doc: Optional[str] = None,
                 uses: Iterable[str] = ()) -> T:
        """Register ``entry`` under ``name`` (``doc``: what it is; by default the first line of the
        entry's docstring); a name registered twice is a programming error."""
        if name in self._specs:
            raise ValueError(f"{self.what} {name!r} is registered twice")
        if doc is None:
            doc = ((getattr(entry, "__doc__", None) or "").strip().splitlines() or [""])[0]
        self._specs[name] = Spec(name, entry, schema, doc, frozenset(uses))
        return entry

    def add(self, name: str, schema: Optional[type] = None, doc: str = "") -> Callable[[T], T]:
        """Decorator form of :meth:`register` (the docstring's first line is the description)."""
        def wrap(entry: T) -> T:
            return self.register(name, entry, schema, doc or None)
        return wrap

    def spec(self, name: str) -> Spec[T]:
        """The :class:`Spec` of ``name``; an unknown name raises ``KeyError`` naming the known ones."""
        try:
            return self._specs[name]
        except KeyError:
            raise KeyError(f"unknown {self.what} {name!r}; known: {', '.join(self._specs)}") from None

    def get(self, name: str) -> T:
        return self.spec(name).entry

    def options(self, name: str, values: Optional[dict[str, Any]] = None) -> Any:
        """``values`` validated by the schema of kind ``name`` (pydantic raises on a foreign key)."""
        schema = self.spec(name).schema
        if schema is None:
            if values:
                raise ValueError(f"{self.what} {name!r} takes no options, not {', '.join(values)}")
            return None
        return schema(**(values or {}))

    def names(self) -> list[str]:
        return list(self._specs)

    def __contains__(self, name: object) -> bool:
        return name in self._specs

    def __iter__(self) -> Iterator[Spec[T]]:
        return iter(self._specs.values())
