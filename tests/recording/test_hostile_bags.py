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
Crafted recordings (issue 30, item 2): ``replay`` and ``plot`` refuse each in one line, fast.

Each bag is the committed ``bags/stack_knocked`` (a world of four boxes) or ``bags/l_block_bin``
(a mesh body) copied record by record with the ``mcap`` library, its ``rbd_ros``
configuration record or its attachments rewritten. Each tool runs as a subprocess under a
2 GiB address-space limit (a bomb cannot take the machine) through a launcher that imports the
tool first (start-up), then runs its ``main`` and reports the CPU time ``main`` took and the
process's peak resident memory (``VmHWM``, which counts only this program, not the pytest
process it was started from). Each must exit 2 with one ``<tool>: error:`` line naming what is
wrong, in under a second of CPU after start-up, its peak memory bounded.
"""

import bz2
import io
import json
import os
from pathlib import Path
import resource
import subprocess
import sys
import zipfile

from mcap.reader import make_reader
from mcap.writer import Writer
import pytest
from rbd_ros.bag.format import CONFIG_METADATA_NAME, load_yaml, MAX_YAML_ITEMS
from rbd_ros.core.errors import RecordingError
from rbd_ros.sim import limits
from rbd_ros.sim.params import MAX_ARRAY_ITEMS, MAX_BODIES, MAX_MESH_FILE_BYTES
import trimesh
import yaml

REPO = Path(__file__).resolve().parents[2]
STACK = REPO / 'bags' / 'stack_knocked' / 'stack_knocked_0.mcap'
L_BLOCK = REPO / 'bags' / 'l_block_bin' / 'l_block_bin_0.mcap'
#: A guard, not the speed target: a refusal that decompressed a bomb (even streamed: bzip2 of
#: 1 GiB costs 3.9 s of CPU here) or built the bodies it claims costs more than this. The
#: target, a second of CPU after start-up, is what each case prints (0.0-0.8 s quiet, the
#: 10^5-body configuration up to 1.1 s under load): speed is measured, not asserted.
REFUSE_CPU_S = 2.0
#: Peak memory of a refusal: the interpreter with numpy, mcap and the tool imported is
#: ~110 MB here; 300 MB leaves room for the largest thing read (a 10 MB configuration text)
#: and is far below what the bombs expand to (2.2 and 3.2 GB before the checks).
PEAK_MB = 300
ADDRESS_SPACE = 2 << 30

LAUNCHER = """
import importlib, json, sys, time
tool, report, argv = sys.argv[1], sys.argv[2], sys.argv[3:]
module = importlib.import_module('rbd_ros.bag.' + tool)
wall, cpu = time.perf_counter(), time.process_time()
status = 2
try:
    status = module.main(argv)
finally:
    hwm = [line for line in open('/proc/self/status') if line.startswith('VmHWM')][0]
    with open(report, 'w') as f:
        json.dump({'cpu_s': time.process_time() - cpu, 'wall_s': time.perf_counter() - wall,
                   'peak_mb': int(hwm.split()[1]) / 1024}, f)
sys.exit(status)
"""


def craft(src, dst, params=None, attachments=None):
    """
    Copy the MCAP file ``src`` to ``dst`` with the ``mcap`` library, record by record.

    :param params: parameters to set in the ``rbd_ros`` configuration record.
    :param attachments: ``[(name, bytes)]`` instead of the source's attachments.
    """
    with open(src, 'rb') as f, open(dst, 'wb') as out:
        reader = make_reader(f)
        writer = Writer(out)
        writer.start(profile=reader.get_header().profile, library='test_hostile_bags')
        summary = reader.get_summary()
        schemas = {s.id: writer.register_schema(s.name, s.encoding, s.data)
                   for s in summary.schemas.values()}
        channels = {c.id: writer.register_channel(c.topic, c.message_encoding,
                                                  schemas.get(c.schema_id, 0), c.metadata)
                    for c in summary.channels.values()}
        for record in reader.iter_metadata():
            metadata = dict(record.metadata)
            if record.name == CONFIG_METADATA_NAME and params:
                config = yaml.safe_load(metadata['config_yaml'])
                config.update(params)
                # libyaml's dumper: PyYAML's own takes ~15 s of CPU for 10^6 names.
                metadata['config_yaml'] = yaml.dump(config, Dumper=yaml.CSafeDumper,
                                                    sort_keys=True)
            writer.add_metadata(record.name, metadata)
        for _, channel, message in reader.iter_messages():
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
        if attachments is None:
            attachments = [(a.name, a.data) for a in reader.iter_attachments()]
        for name, data in attachments:
            writer.add_attachment(0, 0, name, 'model/stl', data)
        writer.finish()
    return dst


def _limited():
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))


def run_tool(tool, bag, tmp_path):
    """Run ``tool`` on ``bag``; return ``(status, error lines, report)``."""
    report = tmp_path / f'{tool}_report.json'
    out = ['--no-progress'] if tool == 'replay' else ['-o', str(tmp_path / 'o.png')]
    args = [str(bag)] + out
    proc = subprocess.run([sys.executable, '-c', LAUNCHER, tool, str(report)] + args,
                          capture_output=True, text=True, timeout=300, preexec_fn=_limited,
                          cwd=str(tmp_path), env=dict(os.environ, PYTHONPATH=str(REPO)))
    errors = [line for line in proc.stderr.splitlines() if not line.startswith(f'{tool}: note:')]
    return proc.returncode, errors, json.loads(report.read_text())


def _stl_attachment():
    """Return the L block's own attachment, under the name its config records."""
    with open(L_BLOCK, 'rb') as f:
        (attachment,) = list(make_reader(f).iter_attachments())
    return attachment.name, attachment.data


def _zip_bomb():
    """Return a zip of one 3 GiB member of zeros (~14 MB compressed), written in 64 MiB pieces."""
    buffer = io.BytesIO()
    piece = bytes(64 << 20)
    # Deflate level 1: 5 s of CPU here instead of 16 s at the default level (a bigger file).
    with zipfile.ZipFile(buffer, 'w', zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
        with archive.open('l_block.stl', 'w', force_zip64=True) as member:
            for _ in range(48):
                member.write(piece)
    return buffer.getvalue()


def _bz2_bomb():
    """
    Return bzip2 data that expands to 3 GiB of zeros (~4 kB): 48 streams of 64 MiB each.

    bzip2 (the tool and Python's :func:`bz2.decompress`) decompresses concatenated streams as
    one file, so one compressed piece repeated is the whole bomb (0.5 s of CPU here instead of
    24 s for compressing 3 GiB).
    """
    return bz2.compress(bytes(64 << 20), 9) * 48


def _bodies(n):
    # The parameter as the node records it (stack_knocked is recorded with today's names).
    return {'body_names': [f'b{i}' for i in range(n)]}


def _box_stl(path):
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(str(path))
    return str(path)


CASES = {  # id: (source, (tmp_path -> craft params, attachments), words of the error line)
    'bodies-1e5': (STACK, lambda tmp: (_bodies(100_000), None),
                   ["the rbd_ros configuration record: the list 'body_names' has more than "
                    f'{MAX_ARRAY_ITEMS} items', 'rbd_ros.sim.params.MAX_ARRAY_ITEMS']),
    'bodies-1e6': (STACK, lambda tmp: (_bodies(1_000_000), None),
                   ["the rbd_ros configuration record: the list 'body_names' has more than "
                    f'{MAX_ARRAY_ITEMS} items', 'rbd_ros.sim.params.MAX_ARRAY_ITEMS']),
    # Within MAX_ARRAY_ITEMS but over MAX_BODIES: the configuration is loaded and its
    # body count refused by the parameter check (the message a user's own file gets).
    'bodies-6000': (STACK, lambda tmp: (_bodies(6000), None),
                    ['parameter body_names = ', f'6000 bodies exceed the limit of {MAX_BODIES}']),
    # An old list name beside its new one (a bag no node writes): refused, not one of them
    # silently read (the reader used to take whichever came last).
    'old-and-new-names': (STACK, lambda tmp: ({'bodies': ['top']}, None),
                          ["parameters bodies = ['top'] and body_names = [",
                           'one list under its old and its new name']),
    'nan-mass-world': (STACK, lambda tmp: ({'bodies.top.mass_kg': float('nan')}, None),
                       ['parameter bodies.top.mass_kg = nan kg: must be finite']),
    'nan-mass-body': (L_BLOCK, lambda tmp: ({'mass_kg': float('nan')}, None),
                      ['parameter mass_kg = nan kg: must be finite']),
    # A valid local mesh the bag names, with no attachment of that name: never read.
    'absolute-path': (L_BLOCK, lambda tmp: ({'mesh_path': _box_stl(tmp / 'local.stl')}, None),
                      ["parameter mesh_path = '", "local.stl': the recording has no attachment "
                       'of that name', 'never from a local file']),
    'not-a-mesh': (L_BLOCK, lambda tmp: (None, [(_stl_attachment()[0], b'hello ' * 40)]),
                   ['l_block.stl', 'is not an STL file (240 bytes', 'no ASCII "solid"']),
    'extra-text-file': (L_BLOCK, lambda tmp: (None, [_stl_attachment(), ('notes.txt', b'hi')]),
                        ["attached mesh 'notes.txt' is a '.txt' file", 'STL or OBJ']),
    'nan-vertex': (L_BLOCK, lambda tmp: (None, [(
        _stl_attachment()[0], b'solid x\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\n'
        b'vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n')]),
        ['l_block.stl', 'has non-finite vertex coordinates']),
    '500MB': (L_BLOCK, lambda tmp: (None, [(_stl_attachment()[0], bytes(500 << 20))]),
              ['is 524288000 bytes, more than the limit of', 'MAX_MESH_BYTES']),
    'bz2-bomb': (L_BLOCK, lambda tmp: ({'mesh_path': 'hull.stl.bz2'},
                                       [('hull.stl.bz2', _bz2_bomb())]),
                 ["'hull.stl.bz2' is bzip2-compressed data, not a mesh",
                  'nothing is decompressed']),
    'zip-bomb': (L_BLOCK, lambda tmp: ({'mesh_path': 'hull.zip'}, [('hull.zip', _zip_bomb())]),
                 ["'hull.zip' is zip-compressed data, not a mesh", 'nothing is decompressed']),
}


@pytest.fixture(scope='module', params=sorted(CASES))
def crafted(request, tmp_path_factory):
    """Write one crafted bag (once for both tools); return ``(case, path, words)``."""
    source, make, words = CASES[request.param]
    tmp = tmp_path_factory.mktemp(request.param)
    params, attachments = make(tmp)
    path = craft(source, tmp / f'{request.param}.mcap', params, attachments)
    return request.param, path, words


@pytest.mark.parametrize('tool', ['replay', 'plot'])
def test_a_crafted_bag_is_refused_in_one_line_fast_and_small(crafted, tool, tmp_path):
    case, bag, words = crafted
    status, errors, report = run_tool(tool, bag, tmp_path)
    print(f'{tool} {case}: exit {status}, {report["cpu_s"]:.3f} s CPU and '
          f'{report["wall_s"]:.3f} s after start-up, peak {report["peak_mb"]:.0f} MB')
    assert status == 2, errors
    assert len(errors) == 1 and errors[0].startswith(f'{tool}: error: '), errors
    assert len(errors[0]) < 1000, errors[0]
    for word in words:
        assert word in errors[0], errors[0]
    assert report['cpu_s'] < REFUSE_CPU_S, report
    assert report['peak_mb'] < PEAK_MB, report


def test_an_intact_copy_replays_and_plots(tmp_path):
    """The copying itself changes nothing: a faithful copy of the mesh bag still matches."""
    bag = craft(L_BLOCK, tmp_path / 'copy.mcap')
    for tool in ('replay', 'plot'):
        status, errors, _ = run_tool(tool, bag, tmp_path)
        assert status == 0 and not errors, (tool, errors)


def test_the_documented_bounds():
    """The numbers doc/recording.md gives; a bag holds any mesh file the node accepts."""
    assert limits.MAX_MESH_BYTES == MAX_MESH_FILE_BYTES == 64 << 20
    assert limits.MAX_MESH_TRIANGLES == 200_000
    assert MAX_YAML_ITEMS == 50 * MAX_BODIES
    assert MAX_ARRAY_ITEMS == 10 * MAX_BODIES


def dump(data):
    """
    Return ``data`` as YAML, by libyaml's emitter where PyYAML has it.

    The same text as ``yaml.safe_dump`` (both sort keys and use block style), written ~4 times
    faster: the pure-Python emitter took ~5 s of CPU per list of MAX_YAML_ITEMS items, most of
    the test below.
    """
    return yaml.dump(data, Dumper=getattr(yaml, 'CSafeDumper', yaml.SafeDumper))


def test_yaml_collections_past_the_item_limit_are_refused_while_parsing():
    """A list or map at its limit is read; one more item is refused, naming its key."""
    at_limit = dump({'body_names': [f'b{i}' for i in range(MAX_YAML_ITEMS)]})
    assert len(load_yaml(at_limit, 'doc')['body_names']) == MAX_YAML_ITEMS
    over = dump({'x': 1, 'nested': {'body_names': list(range(MAX_YAML_ITEMS + 1))}})
    with pytest.raises(RecordingError, match=r"^doc: the list 'body_names' has more than "
                                             f'{MAX_YAML_ITEMS} items'):
        load_yaml(over, 'doc')
    # A configuration's lists are held to the node's bound on an array parameter.
    array = {'body_names': list(range(MAX_ARRAY_ITEMS))}
    assert len(load_yaml(dump(array), 'c', configuration=True)['body_names']) == \
        MAX_ARRAY_ITEMS
    array['body_names'].append(0)
    with pytest.raises(RecordingError, match=r"^c: the list 'body_names' has more than "
                                             f'{MAX_ARRAY_ITEMS} items .*MAX_ARRAY_ITEMS'):
        load_yaml(dump(array), 'c', configuration=True)
    flat = {f'k{i}': i for i in range(MAX_YAML_ITEMS)}
    assert len(load_yaml(dump(flat), 'doc')) == MAX_YAML_ITEMS
    flat[f'k{MAX_YAML_ITEMS}'] = 0
    with pytest.raises(RecordingError, match=f'^doc: the map has more than {MAX_YAML_ITEMS}'):
        load_yaml(dump(flat), 'doc')
    # Parsed by libyaml, read as PyYAML's safe loader reads it.
    text = (REPO / 'msg_config' / 'stack.yaml').read_text()
    assert load_yaml(text, 'doc') == yaml.safe_load(text)
