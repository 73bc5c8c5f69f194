"""Property-based fuzzing of every loader and of the CLI option checks: a valid document
with one field (or one nested field) replaced by an arbitrary value, and arbitrary text as a file.
Whatever comes in, a loader returns a valid object or raises InputError: never another exception.
What it accepts stays in its documented ranges. 2000 generated inputs per loader, derandomised
so CI is repeatable."""
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ecostudy.core.errors import InputError
from ecostudy.io import loaders, schemas
from ecostudy.io.formats import train_document_to_schema, track_document_to_schema, timetable_document_to_schema

from .conftest import DATA, STUDIES, TRACKS, TRAINS, load_yaml

pytestmark = [pytest.mark.filterwarnings("ignore::ecostudy.core.errors.EcostudyWarning"),  # warnings are answers too
              pytest.mark.filterwarnings("ignore::RuntimeWarning"),  # overflow on 1e308 before the range check
              pytest.mark.slow]  # about 50 s: in `make test-slow`, which CI runs
FUZZ = settings(max_examples=2000, derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

values = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-10**12, max_value=10**12),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.sampled_from(["infinity", "inf", "nan", "1e400", "-0", "0100", "", "km/h", "m/s", "%"]),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
    st.dictionaries(st.text(max_size=6), st.integers(), max_size=3),
)


def paths(doc, prefix=()):
    """Every (path to a value) in a nested document."""
    if isinstance(doc, dict):
        for key, value in doc.items():
            yield prefix + (key,)
            yield from paths(value, prefix + (key,))
    elif isinstance(doc, list):
        for i, value in enumerate(doc[:3]):
            yield prefix + (i,)
            yield from paths(value, prefix + (i,))


def mutate(doc, path, value):
    out = json.loads(json.dumps(doc))
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


def mutations(doc):
    every = list(paths(doc))
    return st.tuples(st.sampled_from(every), values).map(lambda pv: mutate(doc, *pv))


def finite_numbers(obj):
    if isinstance(obj, dict):
        return all(finite_numbers(v) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return all(finite_numbers(v) for v in obj)
    return not isinstance(obj, float) or math.isfinite(obj) or obj == math.inf


TRAIN = load_yaml(TRAINS / "amsterdam_metro.yaml")
TRACK = load_yaml(TRACKS / "amsterdam_rokin_centraal.yaml")
STUDY = load_yaml(STUDIES / "metro_supplements.yaml")
NETWORK = load_yaml(STUDIES / "network_metro_2trains.yaml")
TTO_TRAIN = json.loads((DATA / "ttobench_subway_train.json").read_text())
TTO_TRACK = json.loads((DATA / "ttobench_track.json").read_text())
OSRD = json.loads((DATA / "osrd_rolling_stock.json").read_text())
JOURNEY = json.loads((STUDIES / "timetables" / "metro_line_4stops_Journey_01.json").read_text())


@FUZZ
@given(mutations(TRAIN))
def test_train_files(doc):
    try:
        train = loaders.train_from_dict(doc, "fuzz")
    except InputError:
        return
    assert 1000 <= train.static_mass <= 1e8 and train.mass >= train.static_mass
    assert 0.05 <= train.traction_efficiency <= 1 and all(math.isfinite(c) and c >= 0 for c in train.davis)
    assert min(train.das_levels) < 0 < max(train.das_levels)


@FUZZ
@given(mutations(TRACK))
def test_track_files(doc):
    try:
        track = loaders.track_from_dict(doc, "fuzz")
    except InputError:
        return
    assert 0 < track.length <= 2e6 and np.all(np.isfinite(track.limits)) and np.all(track.limits > 0)
    assert np.all(np.isfinite(track.gradients))


def accepted(load, *args):
    """``load(*args)``, or None when it refuses the input with an InputError (any other error fails)."""
    try:
        return load(*args)
    except InputError:
        return None


def published_train(doc):
    data, aliases = train_document_to_schema(doc, "fuzz.json")
    return loaders.train_from_schema(loaders.validate(schemas.TrainFile, data, "fuzz.json"), "fuzz.json", aliases)


def published_track(doc):
    return loaders.track_from_schema(loaders.validate(schemas.TrackFile, track_document_to_schema(doc, "f.json"),
                                                      "f.json"))


@FUZZ
@given(mutations(TTO_TRAIN))
def test_ttobench_trains(doc):
    train = accepted(published_train, doc)
    assert train is None or (math.isfinite(train.max_speed) and train.braking.peak > 0)


@FUZZ
@given(mutations(TTO_TRACK))
def test_ttobench_tracks(doc):
    track = accepted(published_track, doc)
    assert track is None or (np.all(np.isfinite(track.limits)) and np.all(np.isfinite(track.curvatures)))


@FUZZ
@given(mutations(OSRD))
def test_osrd_rolling_stock(doc):
    train = accepted(published_train, doc)
    assert train is None or (math.isfinite(train.max_speed) and train.traction.peak > 0)


@FUZZ
@given(mutations(JOURNEY))
def test_ttobench_journeys(doc):
    accepted(lambda d: loaders.validate(schemas.TimetableFile, timetable_document_to_schema(d, "j.json"), "j.json"),
             doc)


@FUZZ
@given(st.one_of(mutations(STUDY), mutations(NETWORK)))
def test_study_and_network_files(doc):
    schema = schemas.NetworkStudyFile if "trains" in doc else schemas.StudyFile
    try:
        s = loaders.validate(schema, doc, "fuzz.yaml")
    except InputError:
        return
    dumped = s.model_dump()
    for scenario in dumped.get("scenarios") or []:
        scenario.pop("train_overrides")  # untyped here: validated with the train they override (cases.expand)
    assert finite_numbers(dumped)


@FUZZ
@given(st.one_of(st.binary(max_size=300), st.text(max_size=300).map(str.encode)))
def test_arbitrary_bytes_as_a_file(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("fuzz", numbered=True)
    for suffix in (".yaml", ".json"):
        path = folder / f"f{suffix}"
        path.write_bytes(data)
        try:
            loaders.read_document(path)
        except InputError:
            pass


@FUZZ
@given(st.dictionaries(st.sampled_from(["time", "supplement", "points", "workers", "dwell", "count"]),
                       st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**9, 10**9)),
                       min_size=1),
       st.text(max_size=10))
def test_cli_option_checks(options, pair):
    from ecostudy.studies.options import OPTION_RANGES, check_options, parse_pair
    try:
        check_options(**options)
    except InputError:
        pass
    else:
        for name, value in options.items():
            low, high, _ = OPTION_RANGES[name]
            assert math.isfinite(value) and value >= low and (high is None or value <= high)
    for kwargs in ({}, {"ordered": True}, {"nonnegative": True}):
        try:
            a, b = parse_pair(pair, "--pair", **kwargs)
        except InputError:
            continue
        assert math.isfinite(a) and math.isfinite(b)
        assert not kwargs.get("ordered") or 0 <= a <= b


def test_the_fuzz_reaches_every_field():
    """The mutations cover every field of each base document (a generator that missed some would
    pass without testing them)."""
    for doc in (TRAIN, TRACK, TTO_TRAIN, TTO_TRACK, OSRD, JOURNEY, STUDY, NETWORK):
        assert {p[0] for p in paths(doc)} == set(doc)
