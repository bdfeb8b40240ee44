"""jit.py: where compiled code is cached."""

import pytest
import numba
from numba.core import config

from flexmbd.mbd.compiled import jit

pytestmark = pytest.mark.kernel_free


def test_the_cache_stays_in_the_source_hashed_folder_when_numba_reads_the_environment_again(monkeypatch):
    # A worker starts with NUMBA_NUM_THREADS=1 (executor.py): numba's compiler then reads every
    # setting from the environment again; the cache folder must survive that.
    monkeypatch.setenv("NUMBA_FLEXMBD_TEST_RELOAD", "1")
    config.reload_config()
    assert numba.config.CACHE_DIR == str(jit.cache_dir())
    monkeypatch.delenv("NUMBA_FLEXMBD_TEST_RELOAD")
    config.reload_config()
    assert numba.config.CACHE_DIR == str(jit.cache_dir())


def test_the_cache_folder_is_named_after_numba_and_the_compiled_sources():
    d = jit.cache_dir()
    assert d.name == f"numba-{numba.__version__}-{jit.source_hash()}"
    assert len(jit.source_hash()) == 16
    assert any(p.name == "entry.py" for p in jit.compiled_sources())
