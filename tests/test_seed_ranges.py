"""The seed ranges to the seed, the published reserved lists and the secret key's rules: what every
score printed so far depends on."""

import numpy as np
import pytest

from aaai.levels import seeds
from aaai.levels.seeds import (
    OTHER_SEEDS,
    RESERVED_SEEDS,
    TRAIN_SEEDS,
    key_record,
    read_seed_key,
    reserved_seeds,
    seed_range,
    training_seed,
)


def test_the_ranges_are_fixed_and_meet_without_gap_or_overlap():
    assert (TRAIN_SEEDS.start, TRAIN_SEEDS.stop) == (0, 1288490240)
    assert (RESERVED_SEEDS.start, RESERVED_SEEDS.stop) == (1288490240, 1717986944)
    assert (OTHER_SEEDS.start, OTHER_SEEDS.stop) == (1717986944, 2**32)
    assert seeds.RESERVED_KEY == 20241121


@pytest.mark.parametrize(
    "seed, expected",
    [
        (0, TRAIN_SEEDS),
        (1288490239, TRAIN_SEEDS),
        (1288490240, RESERVED_SEEDS),
        (1717986943, RESERVED_SEEDS),
        (1717986944, OTHER_SEEDS),
        (2**32 - 1, OTHER_SEEDS),
    ],
)
def test_each_seed_belongs_to_its_range_a_hair_either_side_of_the_borders(seed, expected):
    assert seed_range(seed) == expected


@pytest.mark.parametrize("seed", [-1, 2**32])
def test_a_seed_outside_every_range_is_refused_with_the_allowed_span(seed):
    with pytest.raises(ValueError) as error:
        seed_range(seed)
    assert str(error.value) == f"seed: got {seed!r}; allowed: an integer from 0 to {2**32 - 1}"


def test_the_published_reserved_lists_never_change():
    # printed by `aaai seeds`, used by every published score: a change here changes them all
    assert reserved_seeds(1, 0, 3) == [1308399469, 1292823318, 1672568734]
    assert reserved_seeds(1, 0, 0) == []
    assert reserved_seeds(1, 0, 1) == [1308399469]
    assert reserved_seeds(0, 1, 3) != reserved_seeds(1, 0, 3)  # level and difficulty both count


def test_a_secret_key_gives_its_own_fixed_list():
    assert reserved_seeds(1, 0, 3, key="abcdefgh") == [1408421026, 1443143708, 1638212321]
    assert reserved_seeds(0, 1, 3, key="abcdefgh") != reserved_seeds(1, 0, 3, key="abcdefgh")


class _Bounds:
    """A generator that answers each draw with the lowest or highest seed it may give, in turn."""

    def __init__(self):
        self.calls, self.high = [], False

    def integers(self, low, high):
        self.calls.append((low, high))
        self.high = not self.high
        return high - 1 if self.high else low


def test_draws_span_exactly_their_range_and_repeats_are_skipped(monkeypatch):
    rng = _Bounds()
    assert training_seed(rng) == TRAIN_SEEDS.stop - 1
    assert rng.calls == [(0, 1288490240)]

    draws = iter([1300000000, 1300000000, 1300000001, 1300000000, 1300000002])

    class Repeating:
        def integers(self, low, high):
            assert (low, high) == (1288490240, 1717986944)
            return next(draws)

    monkeypatch.setattr(np.random, "default_rng", lambda seed: Repeating())
    assert reserved_seeds(1, 0, 3) == [1300000000, 1300000001, 1300000002]


def test_a_scoreboard_records_public_or_a_hash_that_is_not_the_seeds_hash():
    assert key_record(None) == "public"
    assert key_record("abcdefgh") == "sha256:5aee57ddeb583c77b6b5508d71f6978a3aad2102090de1d8a608894a47d5d74a"


def test_the_key_comes_from_the_file_stripped_else_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.delenv("AAAI_SEED_KEY", raising=False)
    assert read_seed_key() is None
    monkeypatch.setenv("AAAI_SEED_KEY", "  12345678\n")
    assert read_seed_key() == "12345678"
    path = tmp_path / "key"
    path.write_text(" secret-key \n")
    assert read_seed_key(path) == "secret-key"
    assert read_seed_key(str(path)) == "secret-key"


def test_a_short_or_missing_key_is_refused_naming_where_it_came_from(tmp_path, monkeypatch):
    monkeypatch.setenv("AAAI_SEED_KEY", " 1234567 ")  # 7 characters once stripped
    with pytest.raises(ValueError) as error:
        read_seed_key()
    assert str(error.value) == ("AAAI_SEED_KEY: the key is 7 characters long; allowed: a key of at least 8 characters")
    path = tmp_path / "key"
    path.write_text("1234567\n")
    with pytest.raises(ValueError) as error:
        read_seed_key(path)
    assert str(error.value) == (
        f"--seed-key-file {str(path)!r}: the key is 7 characters long; allowed: a key of at least 8 characters"
    )
    missing = tmp_path / "none"
    with pytest.raises(ValueError) as error:
        read_seed_key(missing)
    assert str(error.value) == f"--seed-key-file: got {str(missing)!r}; allowed: a readable file holding the key"
    # bytes that are no text are refused, not replaced: two such keys would otherwise read alike
    (tmp_path / "binary").write_bytes(b"\xff\xfe12345678")
    with pytest.raises(ValueError, match="binary.* is not text .byte 0 is not UTF-8"):
        read_seed_key(tmp_path / "binary")
