"""model/cliargs.py: the shared argparse type functions (bpy-free, fast)."""
import argparse
import subprocess
import sys

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ssgi.model import cliargs
from ssgi.model.errors import UserError

from ..conftest import ROOT


def test_parse_size():
    assert cliargs.parse_size("240x135") == (240, 135)
    assert cliargs.parse_size(" 64X36 ").width == 64
    assert str(cliargs.parse_size("64x36")) == "64x36"
    for bad in ("240", "240x", "x135", "240*135", "-4x3", "0x10", "10x0", "16385x1", "2.5x3", ""):
        with pytest.raises(cliargs.ArgError):
            cliargs.parse_size(bad)


@given(st.integers(1, cliargs.MAX_SIZE), st.integers(1, cliargs.MAX_SIZE))
def test_parse_size_roundtrip(w, h):
    s = cliargs.parse_size(f"{w}x{h}")
    assert s == (w, h) and cliargs.parse_size(str(s)) == s


def test_parse_frames():
    assert cliargs.parse_frames("1-4") == (1, 2, 3, 4)
    assert cliargs.parse_frames("7") == (7,)
    assert cliargs.parse_frames("1-3,10, 12-13") == (1, 2, 3, 10, 12, 13)
    assert cliargs.parse_frames("0") == (0,)
    with pytest.raises(cliargs.ArgError, match="backwards"):
        cliargs.parse_frames("5-2")
    with pytest.raises(cliargs.ArgError, match="twice"):
        cliargs.parse_frames("1-3,2")
    for bad in ("", "1,", "a-b", "1-2-3", "1..3"):
        with pytest.raises(cliargs.ArgError):
            cliargs.parse_frames(bad)


def test_parse_shard_partitions_work():
    assert cliargs.parse_shard("0/4") == (0, 4)
    items = list(range(23))
    shards = [cliargs.parse_shard(f"{i}/4") for i in range(4)]
    taken = [x for s in shards for x in s.take(items)]
    assert sorted(taken) == items  # disjoint and complete
    assert all(s.owns(x) for s in shards for x in s.take(items))
    for bad, why in (("4/4", "below the count"), ("1/0", "at least 1"), ("1", "INDEX/COUNT"), ("-1/4", "INDEX/COUNT")):
        with pytest.raises(cliargs.ArgError, match=why):
            cliargs.parse_shard(bad)


def test_numbers_and_paths(tmp_path):
    assert cliargs.positive_int("3") == 3
    assert cliargs.nonnegative_int("0") == 0
    assert cliargs.unit_float("0.25") == 0.25
    assert cliargs.positive_float("1e-3") == 1e-3
    for f, bad in ((cliargs.positive_int, "0"), (cliargs.positive_int, "1.5"), (cliargs.nonnegative_int, "-1"),
                   (cliargs.unit_float, "1.01"), (cliargs.positive_float, "nan"), (cliargs.positive_float, "0")):
        with pytest.raises(cliargs.ArgError):
            f(bad)
    (tmp_path / "f.txt").write_text("x")
    assert cliargs.existing_file(str(tmp_path / "f.txt")).name == "f.txt"
    assert cliargs.existing_dir(str(tmp_path)) == tmp_path
    with pytest.raises(cliargs.ArgError, match="it is a folder"):
        cliargs.existing_file(str(tmp_path))
    with pytest.raises(cliargs.ArgError, match="no such folder"):
        cliargs.existing_dir(str(tmp_path / "nope"))


def test_channel_spec_and_error_types():
    assert cliargs.channel_spec("albedo,normal") == ("albedo", "normal")
    with pytest.raises(cliargs.ArgError, match="bogus"):
        cliargs.channel_spec("albedo,bogus")
    # one exception type serves argparse and the operators (which catch UserError)
    assert issubclass(cliargs.ArgError, UserError) and issubclass(cliargs.ArgError, argparse.ArgumentTypeError)


def test_argparse_names_the_argument_and_exits_2():
    """A bad value exits with status 2 and a message naming the argument and the fault (real argparse, in a
    subprocess so that its sys.exit is observed as a process exit code)."""
    code = ("import sys, argparse; sys.path.insert(0, sys.argv[1]); import cli; cli.load_package();"
            "from ssgi.model import cliargs; p = argparse.ArgumentParser(prog='x');"
            "p.add_argument('--size', type=cliargs.parse_size); p.add_argument('--shard', type=cliargs.parse_shard);"
            "print(p.parse_args(sys.argv[2:]))")
    ok = subprocess.run([sys.executable, "-c", code, str(ROOT), "--size", "64x36", "--shard", "1/2"],
                        capture_output=True, text=True)
    assert ok.returncode == 0 and "Size(width=64, height=36)" in ok.stdout, ok.stderr
    bad = subprocess.run([sys.executable, "-c", code, str(ROOT), "--size", "64by36"], capture_output=True, text=True)
    assert bad.returncode == 2
    assert "argument --size: '64by36' is not WIDTHxHEIGHT" in bad.stderr
    bad = subprocess.run([sys.executable, "-c", code, str(ROOT), "--shard", "3/3"], capture_output=True, text=True)
    assert bad.returncode == 2 and "argument --shard" in bad.stderr and "below the count" in bad.stderr
