"""The chapter 5 replica through the emulator's serial path (issue 7, in part); the whole
demo, as the README shows it, is tests/test_readme_demo.py's."""

import pytest


@pytest.mark.slow
def test_demo_takes_the_old_object_names_with_a_note(cli, tmp_path):
    code, out, err = cli("demo", "--object", "concave", "--via", "sim", "-o", tmp_path)
    assert code == 0, err
    assert err == "tactile demo: note: 'concave' is deprecated, use 'concave_cylinder'\n"
    assert "label concave_cylinder;" in out and (tmp_path / "concave_cylinder").is_dir()
