"""Reading JSON files: one error for bad JSON, one gate for format name and version."""

import pytest

from mnss_kit.errors import UserError
from mnss_kit.fileio import check_format, read_json


class Newer(UserError):
    pass


def test_bad_json_names_the_file(tmp_path):
    path = tmp_path / "x.json"
    path.write_text('{"a": ')
    with pytest.raises(UserError, match=r"x\.json: not valid JSON"):
        read_json(path)
    path.write_bytes(b"\xff\xfe")
    with pytest.raises(UserError, match="not valid JSON"):
        read_json(path)


@pytest.mark.parametrize("data, error, match", [
    ([1], UserError, "not a thing .format is not 'fmt'"),
    ({"format": "other", "v": 1}, UserError, "format is not 'fmt'"),
    ({"format": "fmt"}, UserError, "v must be a positive integer, got None"),
    ({"format": "fmt", "v": True}, UserError, "v must be a positive integer, got True"),
    ({"format": "fmt", "v": 0}, UserError, "v must be a positive integer, got 0"),
    ({"format": "fmt", "v": 3}, Newer, "format version 3 is newer than this mnss-kit reads .up to 2."),
])
def test_format_gate(data, error, match):
    with pytest.raises(error, match=match):
        check_format(data, "f.json", "fmt", "v", 2, "a thing", Newer)


def test_known_versions_pass():
    assert check_format({"format": "fmt", "v": 2}, "f.json", "fmt", "v", 2, "a thing") == 2
