"""The base of every file schema: frozen pydantic models that refuse unknown keys, NaN and
infinity (unless a field says otherwise) and true/false where a number is meant."""
import typing
from typing import Any, ClassVar, Sequence, TypeVar

from pydantic import AfterValidator, BaseModel, ConfigDict, ValidationInfo, field_validator

Values = TypeVar("Values", bound=Sequence[Any])


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True, allow_inf_nan=False)
    # what a whole file of this schema is, in messages ("a track file"); None for a file's parts.
    # ``io.documents.validate`` names the kind a file given in the wrong place is (a track as a train)
    file_kind: ClassVar[str | None] = None

    @field_validator("*", mode="before")
    @classmethod
    def _no_boolean_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        """YAML's ``true`` is 1 to pydantic: refuse it for any field that is not a boolean."""
        if isinstance(value, bool) and info.field_name in cls.model_fields:
            annotation = cls.model_fields[info.field_name].annotation
            if annotation is not bool and bool not in typing.get_args(annotation):
                raise ValueError("expected a number or text, not true/false")
        return value


def unique(field: str, names: Sequence[str]) -> None:
    """Refuse names given twice (a check across items: the message names ``field``, which
    ``io.documents.validate`` then reports the error at)."""
    twice = sorted({n for n in names if list(names).count(n) > 1})
    if twice:
        raise ValueError(f"{field}: names must be unique ({', '.join(map(repr, twice))} given twice)")


def increasing(values: Values, what: str) -> Values:
    if any(b <= a for a, b in zip(values, values[1:])):
        raise ValueError(f"{what} must be strictly increasing")
    return values


def _not_blank(value: str) -> str:
    if not value.strip():
        raise ValueError("an empty name")
    return value


Name = typing.Annotated[str, AfterValidator(_not_blank)]
"""A name (of a stop, a scenario, a train of a fleet, a file's subject): text that is not empty."""
