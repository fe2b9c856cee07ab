""" "Did you mean ...?": the close known names, else every known name (or a pointer to them)."""

from harness.options.suggest import close_matches, did_you_mean


def test_close_names_are_suggested_best_first():
    assert close_matches("altitde_m", ["speed_m_s", "altitude_m"]) == ["altitude_m"]
    assert did_you_mean("cout", ["count", "role", "airframe"]) == "; did you mean count?"


def test_with_nothing_close_every_name_is_listed_or_the_pointer_given():
    assert did_you_mean("zzz", ["count", "role"]) == "; known: count, role"
    assert did_you_mean("zzz", ["count", "role"], listing="there") == "; there: count, role"
    assert did_you_mean("zzz", ["count"], otherwise=" (see the table)") == " (see the table)"
    assert did_you_mean("zzz", []) == ""
