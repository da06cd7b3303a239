"""Configuration files: impossible numbers are refused with the file, key and line."""

import pytest

from bimrobot.config import line_of, number, parse_yaml
from bimrobot.errors import InputError


@pytest.mark.parametrize(
    "value, words",
    [(".nan", "NaN"), (".inf", "infinite"), ("-.inf", "infinite"), ("1e308", "beyond"), ("1" + "0" * 400, "401-digit")],
)
def test_impossible_numbers_are_refused_with_file_key_and_line(value, words):
    text = f"name: f\nrobots:\n  - name: r1\n    load_time: {value}\n"
    with pytest.raises(InputError) as error:
        parse_yaml(text, "fleet.yaml")
    message = str(error.value)
    assert message.startswith("fleet.yaml line 4: key 'robots[0].load_time'") and words in message
    assert len(message) < 200


def test_mappings_know_their_lines_and_number_checks_ranges():
    data = parse_yaml("a: 1\nspeed: -2\n", "site.yaml")
    assert line_of(data, "speed") == " line 2"
    with pytest.raises(InputError, match=r"site.yaml line 2: robot 'x': key 'speed' must be > 0 m/s, got -2"):
        number(data, "speed", "site.yaml", low=0, low_inclusive=False, unit="m/s", where="robot 'x'")
    assert number(data, "a", "site.yaml", low=0, high=10) == 1.0
    assert number(data, "missing", "site.yaml", default=3) == 3.0
    with pytest.raises(InputError, match="key 'missing' is missing"):
        number(data, "missing", "site.yaml")
    with pytest.raises(InputError, match="must be a number"):
        number(parse_yaml("a: fast\n", "f.yaml"), "a", "f.yaml")


def test_syntax_errors_name_the_line():
    with pytest.raises(InputError, match=r"bad.yaml line 2: not valid YAML"):
        parse_yaml("a: [1, 2\nb: 3\n", "bad.yaml")


def test_a_key_given_twice_is_refused_not_silently_overwritten():
    with pytest.raises(InputError, match=r"fleet.yaml line 3: not valid YAML \(key 'speed' appears twice \(first on line 2\)\)"):
        parse_yaml("robot:\n  speed: 1\n  speed: 2\n", "fleet.yaml")
