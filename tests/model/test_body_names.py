"""A body merged from links joined by fixed joints keeps one name however the tree is rooted:
the link the model makes the top of the group (Romeo: ``base_link``, with ``body`` fixed below
it and the legs hanging from ``body``)."""

from __future__ import annotations

import sescid


def _inertial(m: float, z: float) -> str:
    return (f'<inertial><origin xyz="0 0 {z}"/><mass value="{m}"/><inertia ixx="0.01" '
            'ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>')  # fmt: skip


URDF = f"""<robot name="r">
<link name="base_link">{_inertial(2, 0.1)}</link>
<link name="body">{_inertial(1, 0.0)}</link>
<joint name="fix" type="fixed"><parent link="base_link"/><child link="body"/></joint>
<link name="leg">{_inertial(1, -0.2)}</link>
<joint name="hip" type="revolute"><parent link="body"/><child link="leg"/>
<origin xyz="0 0 -0.05"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
</joint>
<link name="foot">{_inertial(0.5, -0.02)}</link>
<joint name="ankle" type="revolute"><parent link="leg"/><child link="foot"/>
<origin xyz="0 0 -0.4"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
</joint>
</robot>"""


def test_the_root_group_keeps_its_top_links_name_from_either_end(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text(URDF)
    at_root = sescid.load_robot(path, "base_link")
    at_foot = sescid.load_robot(path, "foot")
    assert at_root.body_names[0] == "base_link"
    assert "base_link" in at_foot.body_names and "body" not in at_foot.body_names
    assert sorted(at_root.body_names) == sorted(at_foot.body_names)
    i = at_foot.body_names.index("base_link")
    assert at_foot.masses[i] == 3.0  # both links' masses, merged
