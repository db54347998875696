"""Report campaigns that write docs.

The paper's claims (``tumblemc validate``, :mod:`.claims`), the dt-convergence table
(:mod:`.convergence`) and the stress campaign (``tumblemc stress``, :mod:`.stress`). Their
figures are drawn in :mod:`tumblemc.viz`.
"""
