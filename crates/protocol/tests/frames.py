# An encoder of the protocol table (crates/protocol/src/lib.rs) written apart from the crate,
# with Python's struct, binascii.crc_hqx (CRC-16/CCITT-FALSE) and zlib.crc32 (CRC-32/ISO-HDLC):
# it printed the byte constants of tests/frames.rs (`python3 tests/frames.py`).
import struct, binascii, zlib
def f32(*v): return [('f32 %r'%x, struct.pack('<f', x)) for x in v]
def u8(name,v): return [(name, struct.pack('<B', v))]
def u16(name,v): return [(name, struct.pack('<H', v))]
def u32(name,v): return [(name, struct.pack('<I', v))]
def raw(name,b): return [(name, bytes(b))]
MAT_VALUES=[1000.0, 2.0, 0.5, 0.25, 0.0625, 1e-4, 0.001, 0.5, 0.001, 5000.0, 1.0, 0.01]
MAT_NAMES=['stiffness N/m','damping N·s/m','mu_s','mu_d','transition s','converge tol m','stop speed m/s','viscous N·s/m','Karnopp band m/s','bristle stiffness N/m','bristle damping N·s/m','Stribeck speed m/s']
def material():
    out=[]
    for n,v in zip(MAT_NAMES,MAT_VALUES): out+= [('%s %r'%(n,v), struct.pack('<f',v))]
    out+= u8('Stribeck tag: 1 power',1)+u8('exponent 2',2)+u8('model 0 stick-slip',0)
    return out
frames=[
 ('hello', 0x01, 0x0102, u8('software major',1)+u8('minor',2)+u8('patch',3)+u32('scene capacity 8192',8192)+u8('max payload 57',57)),
 ('heartbeat', 0x02, 7, u32('uptime 0x12345678 ms',0x12345678)),
 ('scene_begin', 0x10, 8, u32('total length 300',300)+u32('CRC-32 0xCBF43926',0xCBF43926)),
 ('scene_chunk', 0x11, 9, u32('offset 53',53)+raw('5 bytes "NRBS\\x01"',b'NRBS\x01')),
 ('scene_commit', 0x12, 10, []),
 ('points_planar', 0x13, 11, u8('object 1',1)+u8('patch 2',2)+u16('first point 3',3)+u8('flags: apply',1)+f32(0.5,-0.25,1.0,2.0)),
 ('points_spatial', 0x13, 12, u8('object 0',0)+u8('patch 1',1)+u16('first point 4',4)+u8('flags: spatial, not apply',2)+f32(0.5,0.25,-1.0)),
 ('ack', 0x20, 0, u16('acked seq 0xFFFE',0xFFFE)),
 ('nack', 0x21, 1, u16('rejected seq: unknown 0xFFFF',0xFFFF)+u8('code 2 BadCrc',2)+u8('object: none',0xFF)+u8('patch: none',0xFF)+u16('expected seq 13',13)),
 ('set_material', 0x30, 14, u8('object 2',2)+material()),
 ('enable_forces', 0x31, 15, []),
 ('disable_forces', 0x32, 16, []),
 ('calibrate', 0x33, 17, []),
 ('clear_faults', 0x34, 18, u16('mask 0x8001',0x8001)),
 ('hand_target', 0x35, 19, f32(0.01,0.125)),
 ('excite', 0x36, 20, f32(0.05,-0.05)+u16('half period 20 ms',20)+u16('half period 35 ms',35)+u32('duration 2000 ms',2000)),
 ('status', 0x40, 2, u8('flags: forces on, calibrated',3)+u16('faults 0x0004',4)+u32('scene length 300',300)+u32('scene CRC-32 0xDEADBEEF',0xDEADBEEF)+u32('upload received 106',106)+u16('expected seq 42',42)+u8('last error 16 SceneCrc',16)),
 ('telemetry', 0x50, 3, u32('time 1000000 us',1000000)+f32(0.01,0.02)+f32(0.011,0.0205)+f32(0.0105,0.0203)+f32(1.5)+f32(0.25)+f32(0.5,-1.25)+f32(1e-6)+u16('mu 0.5 = 5000e-4',5000)+u16('tick 37 us',37)+u16('faults 0',0)+u16('feature: vertex 3 = 1<<14 | 3',0x4003)+u8('mode 3 slip | cause 2 breakaway << 4',0x23)),
]
def hexs(b): return ', '.join('0x%02X'%x for x in b)
print('// Printed by tests/frames.py from the protocol table.')
for name,ty,seq,fields in frames:
    payload=b''.join(b for _,b in fields)
    head=bytes([1,ty])+struct.pack('<H',seq)+bytes([len(payload)])
    crc=binascii.crc_hqx(head+payload,0xFFFF)
    print('const %s: &[u8] = &['%name.upper())
    print('    %s, // version 1, type 0x%02X, seq %d, payload %d'%(hexs(head),ty,seq,len(payload)))
    for n,b in fields: print('    %s, // %s'%(hexs(b),n))
    print('    %s, // CRC-16/CCITT-FALSE 0x%04X'%(hexs(struct.pack('<H',crc)),crc))
    print('];')
# a scene: one object, the material above, one degree-1 curve (0,0)-(0.02,0.01) with weights 1, 2
knots=[0.0,0.0,1.0,1.0]; pts=[(0.0,0.0,1.0),(0.04,0.02,2.0)]
fields=raw('magic "NRBS"',b'NRBS')+u8('format version 1',1)+u8('1 object',1)+u16('reserved',0)+material()+u8('1 patch',1)+u8('kind 1: planar curve',1)+u8('degree 1',1)+u16('4 knots',4)+u16('2 points',2)+f32(*knots)+f32(*pts[0])+f32(*pts[1])
sc=b''.join(b for _,b in fields)
print('const SCENE: &[u8] = &[')
for n,b in fields: print('    %s, // %s'%(hexs(b),n))
print('];')
print('const SCENE_CRC32: u32 = 0x%08X; // zlib.crc32, CRC-32/ISO-HDLC, %d bytes'%(zlib.crc32(sc),len(sc)))
