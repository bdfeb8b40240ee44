"""What every other package of flexmbd uses and nothing of flexmbd is used by: the one kind of
bad input (`errors.InputError`, a line naming the file and key), files written whole and named by
their content (`files`: atomic writes, the result cache's folder, content keys), and where the
shipped cases and baselines are (`resources`). It imports only the solver's cache folder
(`flexmbd.mbd.cache`) and the version.
"""
