"""A TTOBench checkout as the cases of one study: every track's consecutive stops, run by every
train that fits the line (``library:`` in a study file, expanded by :mod:`ecostudy.studies.cases`).

A train fits a track when its top speed reaches ``min_speed_share`` of the line's highest limit:
a metro train on an intercity line is another service, not a benchmark of it. Every pair left out
is reported with its reason (``skipped``), never dropped silently.
"""
from pathlib import Path

from ecostudy.core.errors import InputError, problem
from ecostudy.io.loaders import read_track, read_train


def _files(folder, ids, path, what):
    if not folder.is_dir():
        raise InputError(problem(path, "library.path", f"{folder} has no {what}/ folder (not a TTOBench checkout)"))
    found = {f.stem: f for f in sorted(folder.glob("*.json"))}
    if ids is None:
        return list(found.items())
    missing = [i for i in ids if i not in found]
    if missing:
        raise InputError(problem(path, f"library.{what}", f"not in {folder}: {', '.join(missing)}"))
    return [(i, found[i]) for i in ids]


def library_units(lib, base, path):
    """([(name, labels, train document, track document, from, to)], [skipped pair and why])."""
    root = (Path(base) / lib.path).resolve()
    tracks = _files(root / "tracks", lib.tracks, path, "tracks")
    trains = []
    for train_id, train_path in _files(root / "trains", lib.trains, path, "trains"):
        trains.append((train_id, *read_train(train_path)))
    units, skipped = [], []
    for track_id, track_path in tracks:
        doc, track = read_track(track_path)
        top = float(track.limits.max())
        stops = list(track.stops)
        for train_id, train_doc, train in trains:
            if train.max_speed < lib.min_speed_share * top:
                skipped.append({"track": track_id, "train": train_id, "reason": f"top speed {train.max_speed * 3.6:.0f} "
                                f"km/h below {lib.min_speed_share:.0%} of the line's {top * 3.6:.0f} km/h"})
                continue
            for a, b in zip(stops, stops[1:]):
                units.append((f"{track_id}/{train_id}", {"track": track_id, "train": train_id, "from": a, "to": b},
                              train_doc, doc, a, b))
    return units, skipped
