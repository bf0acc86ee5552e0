"""One printed line for a long list: count, first items, where the rest is."""

from sescid.base import listed
from sescid.base.text import ITEM_CHARS, clipped


def test_a_short_list_is_printed_whole():
    assert listed(["a", "b"]) == "a, b"
    assert listed([]) == ""


def test_a_long_list_says_how_many_more_and_where():
    names = [f"LFinger{i}Link" for i in range(20)]
    text = listed(names, where="all in fit.json")
    assert text == "LFinger0Link, LFinger1Link, LFinger2Link (and 17 more; all in fit.json)"


def test_a_long_item_is_cut_at_a_word_and_the_list_says_where_it_is_whole():
    label = " + ".join(f"0.1·r[LFinger{i}Link].x" for i in range(200))  # ~4000 characters
    text = listed([label] * 10, sep="; ", where="all in fit.json")
    assert len(text) < 4 * ITEM_CHARS
    assert text.endswith("(and 7 more; all in fit.json)")
    one = clipped(label)
    assert len(one) <= ITEM_CHARS and one.endswith(" …") and label.startswith(one[:-2])
    assert listed([label], where="in f.json").endswith("(in f.json)")
