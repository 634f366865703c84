# Copyright 2026 The rbd_ros authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
How rbd_ros.core.jitcache compiles.

A kernel called with constants compiles once per argument type; an inlined helper's IR is
copied with one copy of its variables, not one per block.
"""

import inspect
import io

import numba
from rbd_ros.core import jitcache


def _scaled(flag, phase, x):
    if flag:
        return x * phase
    return x - phase


def _caller(callee):
    @numba.njit
    def caller(x):
        return callee(True, 0, x) + callee(False, 1, x) + callee(True, 2, x)
    return caller


def test_constants_do_not_add_specialisations():
    callee = jitcache._once_per_type(numba.njit(_scaled))
    assert _caller(callee)(3.0) == 3.0 * 0 + (3.0 - 1) + 3.0 * 2  # each value still taken
    assert len(callee.signatures) == 1, callee.signatures


def test_without_it_numba_compiles_once_per_constant():
    """The control: what the rule prevents (three calls, three literal signatures)."""
    callee = numba.njit(_scaled)
    _caller(callee)(3.0)
    assert len(callee.signatures) == 3, callee.signatures


def test_every_kernel_gets_the_rule():
    kernel = jitcache.kernel()(_scaled)
    assert kernel.get_call_template.__qualname__.startswith('_once_per_type')


def _piecewise(x):
    if x > 1.0:
        y = x * 2.0
    elif x < -1.0:
        y = -x
    else:
        y = x * x
    return y + 1.0


def _dump(block):
    text = io.StringIO()
    block.dump(text)
    return text.getvalue()


def _copies(sharing):
    """Copy each block of ``_piecewise``'s IR as numba's inline_ir does, sharing or not."""
    from numba.core import compiler
    module = jitcache._share_inline_copies()
    blocks = compiler.run_frontend(_piecewise).blocks
    jitcache._INLINE_COPY.memos = {} if sharing else None
    try:
        return blocks, {label: module.copy.deepcopy(block) for label, block in blocks.items()}
    finally:
        jitcache._INLINE_COPY.memos = None


def test_inlined_ir_blocks_share_one_copy_of_the_scope():
    blocks, copies = _copies(sharing=True)
    assert len(blocks) >= 4  # not vacuous: the branches make blocks
    scopes = {id(block.scope) for block in copies.values()}
    assert len(scopes) == 1
    assert scopes.isdisjoint(id(block.scope) for block in blocks.values())  # a copy
    assert {label: _dump(block) for label, block in copies.items()} == \
        {label: _dump(block) for label, block in blocks.items()}


def test_outside_inline_ir_each_block_copies_the_scope():
    """The control: numba's own per-block copies (what took blocks x variables)."""
    blocks, copies = _copies(sharing=False)
    assert len({id(block.scope) for block in copies.values()}) == len(blocks)


def test_numba_still_copies_inlined_blocks_through_its_copy_module():
    """The hook point: inline_ir deep-copies each block with ``copy.deepcopy`` (numba pinned)."""
    module = jitcache._share_inline_copies()
    original = module.InlineWorker.inline_ir.__wrapped__
    assert 'copy.deepcopy(the_ir.blocks[block_label])' in inspect.getsource(original)
    assert module.copy is jitcache._INLINE_COPY


def test_a_kernel_with_an_inlined_helper_gives_the_helpers_results():
    jitcache._share_inline_copies()
    helper = numba.njit(inline='always')(_piecewise)

    @numba.njit
    def caller(x):
        return helper(x) - helper(-x)
    for x in (2.0, -3.0, 0.5, 1.0):
        assert caller(x) == _piecewise(x) - _piecewise(-x)
    assert jitcache._INLINE_COPY.memos is None  # closed after each inline_ir
