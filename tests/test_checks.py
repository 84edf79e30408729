"""One way to check a setting: the errors name the parameter, and the command line names its flag."""

import pytest

from tendon_id.checks import check_choice, check_choices, check_count, check_keys, check_positive, one_of
from tendon_id.cli import main
from tendon_id.errors import ConfigError


def test_a_choice_is_returned_or_refused_naming_the_parameter_and_the_known_values():
    assert check_choice("tying", "tied", ("tied", "per-guide")) == "tied"
    with pytest.raises(ConfigError) as err:
        check_choice("tying", "loose", ("tied", "per-guide"))
    assert err.value.param == "tying"
    assert str(err.value) == "tying: unknown tying 'loose'; known: tied, per-guide"
    assert check_choices("effects", ["a", "b", "a"], "abc") == ["a", "b"]
    with pytest.raises(ConfigError, match="unknown effect 'z'"):
        check_choices("effects", ["a", "z"], "abc", what="effect")
    assert one_of(["a", "b", "c"]) == "a, b or c" and one_of(["a"]) == "a"


def test_counts_positives_and_keys():
    assert check_count("frames", 5, 2) == 5
    with pytest.raises(ConfigError, match="frames: must be at least 2, got 1"):
        check_count("frames", 1, 2)
    with pytest.raises(ConfigError, match="must be a whole number"):
        check_count("frames", 2.5)
    with pytest.raises(ConfigError, match="must be a whole number"):
        check_count("frames", True)
    assert check_positive("warmup_s", 0, allow_zero=True) == 0.0
    for bad in (0, -1, float("nan"), float("inf"), "x"):
        with pytest.raises(ConfigError, match="warmup_s: must be a positive number in s"):
            check_positive("warmup_s", bad, "s")
    check_keys({"a": 1}, ("a", "b"))
    with pytest.raises(ConfigError, match=r"r.toml: unknown section\(s\) 'c', 'd'; known: a, b"):
        check_keys({"a": 1, "d": 2, "c": 3}, ("a", "b"), what="section", where="r.toml")


def test_a_library_error_names_the_flag_of_the_command_that_ran(tmp_path, capsys):
    code = main(["simulate", "--frames", "1", "--out", str(tmp_path / "x.parquet")])
    err = capsys.readouterr().err
    assert code == 2 and err == "tendon-id: error: --frames: must be at least 2, got 1\n"
    code = main(["benchmark", "table2", "--points", "3"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("tendon-id: error: --points: the table2 benchmark does not take it")
    code = main(["fit", "capstan-simple", "--set", "bogus=1", "--data", "x.parquet", "--out", str(tmp_path / "m")])
    err = capsys.readouterr().err  # a model setting has no flag of its own: its name is said
    assert code == 2 and err.startswith("tendon-id: error: bogus: no setting of model 'capstan-simple'")
