"""Every number that README.md and docs/*.md state is recomputed by the code that measures it (tests/claims.py):
the quick claims here, the full ones under ``pytest -m claims``."""
import pytest

from .claims import CLAIMS, MARKED, PAGES, disagreement, stated

STATED = stated()
QUICK = sorted({name for _, name, _ in STATED if name in CLAIMS and not CLAIMS[name].full})
FULL = sorted({name for _, name, _ in STATED if name in CLAIMS and CLAIMS[name].full})


def test_every_stated_claim_is_made_by_code_and_every_claim_is_stated():
    names = {name for _, name, _ in STATED}
    assert not names - set(CLAIMS), f"claims the pages state that no code makes: {sorted(names - set(CLAIMS))}"
    assert not set(CLAIMS) - names, f"claims no page states: {sorted(set(CLAIMS) - names)}"
    for page in PAGES:  # a marker left unclosed would hide a number from every check
        text = page.read_text()
        assert text.count("<!-- claim ") == len(MARKED.findall(text)) == text.count("<!-- /claim -->"), page.name
    assert all(text.strip() for _, _, text in STATED), "a claim that states nothing: write it with --write"


def _check(name):
    item = CLAIMS[name]
    made = item.make()
    for page, stated_name, text in STATED:
        if stated_name == name:
            why = disagreement(item, text, made)
            assert why is None, f"{page.name}, claim {name}: {why}"


@pytest.mark.parametrize("name", QUICK)
def test_a_stated_number_is_what_the_code_gives(name):
    _check(name)


@pytest.mark.claims
@pytest.mark.parametrize("name", FULL)
def test_a_stated_number_is_what_the_full_command_gives(name):
    _check(name)


def test_the_kinds_of_claim_are_judged_as_they_say():
    from .claims import Claim

    exact, bound, measured = (Claim("x", None, kind) for kind in ("exact", "bound", "measured"))
    assert disagreement(exact, " 17.99 s ", "17.99 s") is None and disagreement(exact, "17.99 s", "17.98 s")
    assert disagreement(bound, "below 1e-9 over 10 s, below 1e-8", [5e-10, 9e-9]) is None
    assert "not below" in disagreement(bound, "below 1e-9 over 10 s, below 1e-8", [5e-10, 2e-8])
    assert disagreement(measured, "about 1.5 minutes", "about 3 minutes") is None
    assert "factor" in disagreement(measured, "about 1.5 minutes", "about 4 minutes")
