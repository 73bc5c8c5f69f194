"""Property-based fuzzing of every loader, every study kind's file and the CLI option checks: a
valid document with one field (or one nested field) replaced by an arbitrary value, and arbitrary
text as a file. Whatever comes in, a loader returns a valid object or raises InputError: never
another exception. What it accepts stays in its documented ranges.

Two hypothesis profiles, derandomised so CI is repeatable: every fuzz test runs twice, with a small
example budget in the fast suite (``make test``) and with the deep one (2000 inputs per test) in the
slow suite (``-m slow``). :func:`fuzz` makes the pair."""
import json
import math
import signal
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ecostudy.core.errors import InputError
from ecostudy.io import loaders, schemas
from ecostudy.io.formats import train_document_to_schema, track_document_to_schema, timetable_document_to_schema

from .conftest import DATA, STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

pytestmark = [pytest.mark.filterwarnings("ignore::ecostudy.core.errors.EcostudyWarning"),  # warnings are answers too
              pytest.mark.filterwarnings("ignore::RuntimeWarning")]  # overflow on 1e308 before the range check
COMMON = {"derandomize": True, "deadline": None, "database": None,
          "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large,
                                    HealthCheck.function_scoped_fixture]}
settings.register_profile("fast", max_examples=60, **COMMON)
settings.register_profile("deep", max_examples=2000, **COMMON)


def fuzz(*strategies, fast=None, deep=None):
    """``(test, test_deep)`` of one property: the fast profile's budget (``fast`` examples if given)
    in ``make test``, the deep one's (``deep`` if given) marked slow."""
    def pair(body):
        quick = settings(settings.get_profile("fast"), **({"max_examples": fast} if fast else {}))(given(*strategies)(body))
        thorough = settings(settings.get_profile("deep"), **({"max_examples": deep} if deep else {}))(
            given(*strategies)(body))
        return quick, pytest.mark.slow(thorough)
    return pair


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


def _train_files(doc):
    try:
        train = loaders.train_from_dict(doc, "fuzz")
    except InputError:
        return
    assert 1000 <= train.static_mass <= 1e8 and train.mass >= train.static_mass
    assert 0.05 <= train.traction_efficiency <= 1 and all(math.isfinite(c) and c >= 0 for c in train.davis)
    assert min(train.das_levels) < 0 < max(train.das_levels)


test_train_files, test_train_files_deep = fuzz(mutations(TRAIN))(_train_files)


def _track_files(doc):
    try:
        track = loaders.track_from_dict(doc, "fuzz")
    except InputError:
        return
    assert 0 < track.length <= 2e6 and np.all(np.isfinite(track.limits)) and np.all(track.limits > 0)
    assert np.all(np.isfinite(track.gradients))


test_track_files, test_track_files_deep = fuzz(mutations(TRACK))(_track_files)


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


def _ttobench_trains(doc):
    train = accepted(published_train, doc)
    assert train is None or (math.isfinite(train.max_speed) and train.braking.peak > 0)


test_ttobench_trains, test_ttobench_trains_deep = fuzz(mutations(TTO_TRAIN))(_ttobench_trains)


def _ttobench_tracks(doc):
    track = accepted(published_track, doc)
    assert track is None or (np.all(np.isfinite(track.limits)) and np.all(np.isfinite(track.curvatures)))


test_ttobench_tracks, test_ttobench_tracks_deep = fuzz(mutations(TTO_TRACK))(_ttobench_tracks)


def _osrd_rolling_stock(doc):
    train = accepted(published_train, doc)
    assert train is None or (math.isfinite(train.max_speed) and train.traction.peak > 0)


test_osrd_rolling_stock, test_osrd_rolling_stock_deep = fuzz(mutations(OSRD))(_osrd_rolling_stock)


def _ttobench_journeys(doc):
    accepted(lambda d: loaders.validate(schemas.TimetableFile, timetable_document_to_schema(d, "j.json"), "j.json"),
             doc)


test_ttobench_journeys, test_ttobench_journeys_deep = fuzz(mutations(JOURNEY))(_ttobench_journeys)


def _study_and_network_files(doc):
    schema = schemas.NetworkStudyFile if "trains" in doc else schemas.StudyFile
    try:
        s = loaders.validate(schema, doc, "fuzz.yaml")
    except InputError:
        return
    dumped = s.model_dump()
    for scenario in dumped.get("scenarios") or []:
        scenario.pop("train_overrides")  # untyped here: validated with the train they override (cases.expand)
    assert finite_numbers(dumped)


test_study_and_network_files, test_study_and_network_files_deep = fuzz(st.one_of(mutations(STUDY), mutations(NETWORK)))(_study_and_network_files)


def _arbitrary_bytes_as_a_file(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("fuzz", numbered=True)
    for suffix in (".yaml", ".json"):
        path = folder / f"f{suffix}"
        path.write_bytes(data)
        try:
            loaders.read_document(path)
        except InputError:
            pass


test_arbitrary_bytes_as_a_file, test_arbitrary_bytes_as_a_file_deep = fuzz(st.one_of(st.binary(max_size=300), st.text(max_size=300).map(str.encode)))(_arbitrary_bytes_as_a_file)


def _cli_option_checks(options, pair):
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


test_cli_option_checks, test_cli_option_checks_deep = fuzz(st.dictionaries(st.sampled_from(["time", "supplement", "points", "workers", "dwell", "count"]),
                       st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**9, 10**9)),
                       min_size=1),
       st.text(max_size=10))(_cli_option_checks)


# ------------------------------------------------------------------- study kinds, timetables, journeys
LOOP = load_yaml(STUDIES / "metro_monte_carlo.yaml")
HEAVY = load_yaml(STUDIES / "heavyhaul_fence.yaml")
CONSIST = load_yaml(TRAINS / "heavyhaul_zhang_zhuan.yaml")
TIMETABLE = load_yaml(STUDIES / "timetables" / "metro_line.yaml")
LINE4 = loaders.load_track(TRACKS / "metro_line_4stops.yaml")
BOUND_S = 120  # no input may keep a check busy longer: a hang fails the test


@contextmanager
def bounded(seconds=BOUND_S):
    """Fail (not hang) when the block runs longer than ``seconds``."""
    def alarm(*_):
        raise TimeoutError(f"no answer within {seconds} s")
    before = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, before)


def names_given(dumped):
    """Every ``name`` of an accepted document is a real name (not empty, not blank)."""
    if isinstance(dumped, dict):
        return all((k != "name" or (isinstance(v, str) and v.strip())) and names_given(v) for k, v in dumped.items())
    if isinstance(dumped, (list, tuple)):
        return all(names_given(v) for v in dumped)
    return True


def _closed_loop_files(doc):
    from ecostudy.io.loopfile import SimulateFile
    s = accepted(loaders.validate, SimulateFile, doc, "loop.yaml")
    if s is None:
        return
    dumped = s.model_dump()
    assert finite_numbers(dumped) and names_given(dumped)
    assert 0 <= s.window_s[0] <= s.window_s[1] and 0 < s.sample_time_s and 10 <= s.points <= 20000
    assert all(0 < (c.sample_time_s or s.sample_time_s) < s.window_s[1] for c in s.controllers)


test_closed_loop_files, test_closed_loop_files_deep = fuzz(mutations(LOOP))(_closed_loop_files)


def _heavyhaul_files(pair):
    study, consist = pair
    from ecostudy.io.heavyhaulfile import HeavyhaulFile
    s = accepted(loaders.validate, HeavyhaulFile, study, "hh.yaml")
    if s is not None:
        dumped = s.model_dump()
        assert finite_numbers(dumped) and names_given(dumped) and s.sample_time_s > 0
        assert all(f >= 1 for f in s.fence) and all(1 <= h.nc <= h.np for h in s.horizons)
    c = accepted(loaders.consist_from_document, consist, "consist.yaml")
    if c is not None:
        assert c.cars >= 2 and np.all(np.isfinite(c.mass)) and np.all(c.mass > 0) and 0 < c.force_limit < np.inf


test_heavyhaul_files, test_heavyhaul_files_deep = fuzz(
    st.one_of(st.tuples(mutations(HEAVY), st.just(CONSIST)), st.tuples(st.just(HEAVY), mutations(CONSIST))))(
    _heavyhaul_files)


def _timetables_on_a_track(doc, dwell):
    """A timetable (YAML or a TTOBench journey) named on its track and planned as ``journey`` does."""
    from ecostudy.io.timetable import journey_plan, name_stops
    tt = accepted(loaders.validate, schemas.TimetableFile, doc, "tt.yaml")
    if tt is None:
        return
    named = accepted(name_stops, tt, LINE4, "tt.yaml")
    if named is None:
        return
    plan = accepted(journey_plan, named[0], named[1], "tt.yaml", dwell)
    if plan is not None:
        assert len(plan.stops) >= 2 and all(d >= 0 for d in plan.dwell)


test_timetables_on_a_track, test_timetables_on_a_track_deep = fuzz(
    mutations(TIMETABLE), st.one_of(st.just(20.0), st.floats(0, 1e4)))(_timetables_on_a_track)


def study_documents():
    """A run study, a network study and a closed-loop study (paths made absolute), one field replaced."""
    run = dict(STUDY, track=str(TRACKS / "amsterdam_rokin_centraal.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"))
    net = dict(NETWORK, track=str(TRACKS / "metro_line_4stops.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"))
    loop = dict(LOOP, track=str(TRACKS / "amsterdam_rokin_centraal.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"),
                draws=2)
    return st.one_of(mutations(run), mutations(net), mutations(loop))


def _whole_study_checks(tmp_path_factory, doc):
    """The checks a study command makes before computing (cases, estimates, sizes): a refusal or a
    pass, never another exception, and within the bound."""
    from ecostudy.studies import sizes
    path = write_yaml(tmp_path_factory.mktemp("study", numbered=True) / "study.yaml", doc)
    with bounded():
        try:
            if "controllers" in doc:
                sizes.check_closed_loop_study(path, 2)
            elif "trains" in doc:
                sizes.check_network_study(loaders.load_network_study(path), path, 2)
            else:
                sizes.check_run_study(path, 2)
        except InputError:
            pass


test_whole_study_checks, test_whole_study_checks_deep = fuzz(study_documents(), fast=25, deep=300)(
    _whole_study_checks)


def test_the_fuzz_reaches_every_field():
    """The mutations cover every field of each base document (a generator that missed some would
    pass without testing them)."""
    for doc in (TRAIN, TRACK, TTO_TRAIN, TTO_TRACK, OSRD, JOURNEY, STUDY, NETWORK, LOOP, HEAVY, CONSIST, TIMETABLE):
        assert {p[0] for p in paths(doc)} == set(doc)
