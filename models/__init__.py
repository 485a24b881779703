"""Named robots of the paper as MJCF files (Table 1: gymnast.xml, Table 2: example2.xml)."""
