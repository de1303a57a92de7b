"""Two runs of one scan compared stage by stage (results and array hashes), and what is damaged in a run directory (``ares rerun``, ``ares batch --rerun``)."""

from __future__ import annotations



def _comparable(stage: dict) -> dict:
    return {k: v for k, v in stage.items() if k not in ("timing", "arrays_sha256", "h5_bytes")}


def compare(a, b) -> tuple[int, int, list[str]]:
    """(identical stages, stages compared, what differs): the stages of ``a`` by index
    against ``b``'s -- each stage's results, and its arrays by the SHA-256 each run recorded
    when it wrote them (``ares.rundir.check``), naming the array that differs."""
    theirs = {st["index"]: st for st in b.stages}
    n, diff = 0, []
    for st in a.stages:
        other = theirs.get(st["index"])
        if other is None:
            continue
        n += 1
        what = f"stage {st['index']} '{st['name']}'"
        if _comparable(st) != _comparable(other):
            diff.append(f"{what}: results")
            continue
        ha, hb = st.get("arrays_sha256"), other.get("arrays_sha256")
        if isinstance(ha, dict) and isinstance(hb, dict):
            bad = sorted(k for k in set(ha) | set(hb) if ha.get(k) != hb.get(k))
            if bad:
                diff.append(f"{what}: array{'s' if len(bad) > 1 else ''} {', '.join(bad)}")
    return n - len(diff), n, diff


def original_damage(rec) -> str:
    """"" when the original run directory is as written, else one sentence: that of
    ``ares.rundir.check`` (incomplete / corrupt: stage N ...) and every file of the manifest
    (``ares.rundir.manifest``) that is missing or altered, reports included."""
    from ares.rundir.check import RunDamaged, check_run

    from ares.rundir import manifest

    found = manifest.problems(rec.dir)  # every file the run and its reports wrote
    try:
        check_run(rec.dir, rec.meta, rec.stages, arrays=True)
    except RunDamaged as exc:
        return str(exc) + (f"; and {manifest.sentence(rec.dir, found)}" if found else "")
    return manifest.sentence(rec.dir, found) if found else ""
