"""The paper's own numbers (Eraqi et al., 2016), in one place: what every table, summary and
document sets the reproduced results beside."""

from __future__ import annotations

# §5.4, Table 1: fitness (steps) of the controller trained on strategy i, deployed on j.
PAPER_TABLE1 = [[2115, 544, 558, 432], [595, 2305, 136, 931], [159, 351, 3050, 460],
                [559, 334, 1080, 2560]]
# §5.4.1, Table 2: incremental evolution, iteration i's fitness on strategies 1..i+1.
PAPER_TABLE2 = [[1936], [2380, 1452], [1970, 2123, 1467]]
# §5.5, Tables 3 and 4: (initial, after) collision rates of strategies 1–4.
PAPER_TABLE3 = [(16.33, 3.90), (20.05, 4.59), (16.82, 8.00), (13.49, 12.27)]
PAPER_TABLE4 = [(16.33, 2.11), (20.05, 1.58), (16.82, 1.76), (13.49, 1.90)]
# The initial rates Tables 3 and 4 share.
PAPER_INITIAL = [initial for initial, _ in PAPER_TABLE3]
# The mean reduction of the collision rate over the four strategies, Tables 3 and 4.
PAPER_REDUCTION = {name: sum(1 - after / before for before, after in table) / len(table)
                   for name, table in (("table3", PAPER_TABLE3), ("table4", PAPER_TABLE4))}
