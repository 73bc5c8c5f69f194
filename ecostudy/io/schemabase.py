"""The base of every file schema: frozen pydantic models that refuse unknown keys, NaN and
infinity (unless a field says otherwise) and true/false where a number is meant, in a list too."""
import typing
from typing import Any, ClassVar, Sequence, TypeVar

from pydantic import AfterValidator, BaseModel, ConfigDict, ValidationError, ValidationInfo, field_validator
from pydantic_core import InitErrorDetails, PydanticCustomError

Values = TypeVar("Values", bound=Sequence[Any])


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True, allow_inf_nan=False)
    # what a whole file of this schema is, in messages ("a track file"); None for a file's parts.
    # ``io.documents.validate`` names the kind a file given in the wrong place is (a track as a train)
    file_kind: ClassVar[str | None] = None

    @field_validator("*", mode="before")
    @classmethod
    def _no_boolean_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        """YAML's ``true`` is 1 to pydantic: refuse it for any field that is not a boolean, and in a
        list of numbers (``sweep: {supplement_percent: [true, 10]}`` ran a 1 % case), named by its
        place (``sweep.supplement_percent[0]``)."""
        if info.field_name not in cls.model_fields:
            return value
        annotation = cls.model_fields[info.field_name].annotation
        if isinstance(value, bool) and annotation is not bool and bool not in typing.get_args(annotation):
            raise ValueError(BOOLEAN)
        place = _boolean_item(value, annotation)
        if place is not None:
            error = PydanticCustomError("bool_not_number", BOOLEAN)
            raise ValidationError.from_exception_data(cls.__name__, [InitErrorDetails(type=error, loc=place,
                                                                                      input=True)])
        return value


BOOLEAN = "expected a number or text, not true/false"


def _boolean_item(value: Any, annotation: Any) -> tuple[int, ...] | None:
    """The place (indices) of the first true/false in ``value``, a list (of lists) whose items
    ``annotation`` (a field's: ``Optional[list[float]]``) says are numbers; None where there is none."""
    if not isinstance(value, (list, tuple)):
        return None
    items = next((typing.get_args(a) for a in (annotation, *typing.get_args(annotation))
                  if typing.get_origin(a) in (list, tuple)), None)
    if not items:
        return None
    for i, item in enumerate(value):
        kind = items[min(i, len(items) - 1)] if items[-1] is not Ellipsis else items[0]
        if isinstance(item, bool) and _number(kind) and not _admits(kind, bool):
            return (i,)
        inner = _boolean_item(item, kind)
        if inner is not None:
            return (i, *inner)
    return None


def _admits(annotation: Any, kind: type) -> bool:
    """Whether a type (``Annotated``, ``Optional``, a union) admits ``kind``."""
    return annotation is kind or annotation is Any or any(_admits(a, kind) for a in typing.get_args(annotation))


def _number(annotation: Any) -> bool:
    return _admits(annotation, float) or _admits(annotation, int)


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


def _file_name_part(value: str) -> str:
    """Refuse a name that cannot be part of a file name in the output folder as it is: a path
    separator, '..', a leading dot or a control character (``../../x`` wrote outside ``--out``,
    ``a/b`` into a folder of its own)."""
    if "/" in value or "\\" in value:
        raise ValueError(f"{value!r}: a path separator ('/' or a backslash) in a name that becomes part of a file name")
    if ".." in value or value.startswith("."):
        raise ValueError(f"{value!r}: '..' or a leading '.' in a name that becomes part of a file name")
    if any(ord(c) < 32 or ord(c) == 127 for c in value):
        raise ValueError(f"{value!r}: a control character in a name that becomes part of a file name")
    return value


FileName = typing.Annotated[str, AfterValidator(_not_blank), AfterValidator(_file_name_part)]
"""A :data:`Name` that becomes part of an output file's name (a closed-loop controller's:
``steps/<name>_draw<i>.csv``): no path separator, no '..', no leading dot, no control character."""
