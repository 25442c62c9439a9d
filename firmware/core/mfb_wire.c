#include "mfb_wire.h"

/* Byte offsets: the table of docs/mfb-protocol.md. */
enum {
  kMagicAt = 0, kVersionAt = 4, kTypeAt = 5, kLengthAt = 6, kSessionAt = 8, kSequenceAt = 12,
  kCmdHostTimeAt = 16, kCmdDaAt = 24, kCmdDigitalOutAt = 40, kCmdFlagsAt = 41, kCmdBoardNonceAt = 42,
  kStEchoAt = 16, kStBoardTimeAt = 24, kStAckAt = 32, kStAdAt = 36, kStEncoderAt = 68,
  kStDigitalInAt = 100, kStStatusAt = 101, kStBoardNonceAt = 102, kStBootIdAt = 110, kStLimitVentedAt = 114,
  kStLimitMotorOffAt = 116
};

/* 1 KiB of flash, no RAM: CRC-32C of each byte value (reflected polynomial 0x82F63B78). */
static const uint32_t kCrcTable[256] = {
    0x00000000u, 0xF26B8303u, 0xE13B70F7u, 0x1350F3F4u, 0xC79A971Fu, 0x35F1141Cu,
    0x26A1E7E8u, 0xD4CA64EBu, 0x8AD958CFu, 0x78B2DBCCu, 0x6BE22838u, 0x9989AB3Bu,
    0x4D43CFD0u, 0xBF284CD3u, 0xAC78BF27u, 0x5E133C24u, 0x105EC76Fu, 0xE235446Cu,
    0xF165B798u, 0x030E349Bu, 0xD7C45070u, 0x25AFD373u, 0x36FF2087u, 0xC494A384u,
    0x9A879FA0u, 0x68EC1CA3u, 0x7BBCEF57u, 0x89D76C54u, 0x5D1D08BFu, 0xAF768BBCu,
    0xBC267848u, 0x4E4DFB4Bu, 0x20BD8EDEu, 0xD2D60DDDu, 0xC186FE29u, 0x33ED7D2Au,
    0xE72719C1u, 0x154C9AC2u, 0x061C6936u, 0xF477EA35u, 0xAA64D611u, 0x580F5512u,
    0x4B5FA6E6u, 0xB93425E5u, 0x6DFE410Eu, 0x9F95C20Du, 0x8CC531F9u, 0x7EAEB2FAu,
    0x30E349B1u, 0xC288CAB2u, 0xD1D83946u, 0x23B3BA45u, 0xF779DEAEu, 0x05125DADu,
    0x1642AE59u, 0xE4292D5Au, 0xBA3A117Eu, 0x4851927Du, 0x5B016189u, 0xA96AE28Au,
    0x7DA08661u, 0x8FCB0562u, 0x9C9BF696u, 0x6EF07595u, 0x417B1DBCu, 0xB3109EBFu,
    0xA0406D4Bu, 0x522BEE48u, 0x86E18AA3u, 0x748A09A0u, 0x67DAFA54u, 0x95B17957u,
    0xCBA24573u, 0x39C9C670u, 0x2A993584u, 0xD8F2B687u, 0x0C38D26Cu, 0xFE53516Fu,
    0xED03A29Bu, 0x1F682198u, 0x5125DAD3u, 0xA34E59D0u, 0xB01EAA24u, 0x42752927u,
    0x96BF4DCCu, 0x64D4CECFu, 0x77843D3Bu, 0x85EFBE38u, 0xDBFC821Cu, 0x2997011Fu,
    0x3AC7F2EBu, 0xC8AC71E8u, 0x1C661503u, 0xEE0D9600u, 0xFD5D65F4u, 0x0F36E6F7u,
    0x61C69362u, 0x93AD1061u, 0x80FDE395u, 0x72966096u, 0xA65C047Du, 0x5437877Eu,
    0x4767748Au, 0xB50CF789u, 0xEB1FCBADu, 0x197448AEu, 0x0A24BB5Au, 0xF84F3859u,
    0x2C855CB2u, 0xDEEEDFB1u, 0xCDBE2C45u, 0x3FD5AF46u, 0x7198540Du, 0x83F3D70Eu,
    0x90A324FAu, 0x62C8A7F9u, 0xB602C312u, 0x44694011u, 0x5739B3E5u, 0xA55230E6u,
    0xFB410CC2u, 0x092A8FC1u, 0x1A7A7C35u, 0xE811FF36u, 0x3CDB9BDDu, 0xCEB018DEu,
    0xDDE0EB2Au, 0x2F8B6829u, 0x82F63B78u, 0x709DB87Bu, 0x63CD4B8Fu, 0x91A6C88Cu,
    0x456CAC67u, 0xB7072F64u, 0xA457DC90u, 0x563C5F93u, 0x082F63B7u, 0xFA44E0B4u,
    0xE9141340u, 0x1B7F9043u, 0xCFB5F4A8u, 0x3DDE77ABu, 0x2E8E845Fu, 0xDCE5075Cu,
    0x92A8FC17u, 0x60C37F14u, 0x73938CE0u, 0x81F80FE3u, 0x55326B08u, 0xA759E80Bu,
    0xB4091BFFu, 0x466298FCu, 0x1871A4D8u, 0xEA1A27DBu, 0xF94AD42Fu, 0x0B21572Cu,
    0xDFEB33C7u, 0x2D80B0C4u, 0x3ED04330u, 0xCCBBC033u, 0xA24BB5A6u, 0x502036A5u,
    0x4370C551u, 0xB11B4652u, 0x65D122B9u, 0x97BAA1BAu, 0x84EA524Eu, 0x7681D14Du,
    0x2892ED69u, 0xDAF96E6Au, 0xC9A99D9Eu, 0x3BC21E9Du, 0xEF087A76u, 0x1D63F975u,
    0x0E330A81u, 0xFC588982u, 0xB21572C9u, 0x407EF1CAu, 0x532E023Eu, 0xA145813Du,
    0x758FE5D6u, 0x87E466D5u, 0x94B49521u, 0x66DF1622u, 0x38CC2A06u, 0xCAA7A905u,
    0xD9F75AF1u, 0x2B9CD9F2u, 0xFF56BD19u, 0x0D3D3E1Au, 0x1E6DCDEEu, 0xEC064EEDu,
    0xC38D26C4u, 0x31E6A5C7u, 0x22B65633u, 0xD0DDD530u, 0x0417B1DBu, 0xF67C32D8u,
    0xE52CC12Cu, 0x1747422Fu, 0x49547E0Bu, 0xBB3FFD08u, 0xA86F0EFCu, 0x5A048DFFu,
    0x8ECEE914u, 0x7CA56A17u, 0x6FF599E3u, 0x9D9E1AE0u, 0xD3D3E1ABu, 0x21B862A8u,
    0x32E8915Cu, 0xC083125Fu, 0x144976B4u, 0xE622F5B7u, 0xF5720643u, 0x07198540u,
    0x590AB964u, 0xAB613A67u, 0xB831C993u, 0x4A5A4A90u, 0x9E902E7Bu, 0x6CFBAD78u,
    0x7FAB5E8Cu, 0x8DC0DD8Fu, 0xE330A81Au, 0x115B2B19u, 0x020BD8EDu, 0xF0605BEEu,
    0x24AA3F05u, 0xD6C1BC06u, 0xC5914FF2u, 0x37FACCF1u, 0x69E9F0D5u, 0x9B8273D6u,
    0x88D28022u, 0x7AB90321u, 0xAE7367CAu, 0x5C18E4C9u, 0x4F48173Du, 0xBD23943Eu,
    0xF36E6F75u, 0x0105EC76u, 0x12551F82u, 0xE03E9C81u, 0x34F4F86Au, 0xC69F7B69u,
    0xD5CF889Du, 0x27A40B9Eu, 0x79B737BAu, 0x8BDCB4B9u, 0x988C474Du, 0x6AE7C44Eu,
    0xBE2DA0A5u, 0x4C4623A6u, 0x5F16D052u, 0xAD7D5351u,
};

uint32_t mfb_crc32c(const uint8_t* data, size_t size) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) crc = (crc >> 8) ^ kCrcTable[(crc ^ data[i]) & 0xFFu];
  return crc ^ 0xFFFFFFFFu;
}

static void put_u16(uint8_t* p, size_t at, uint16_t v) {
  p[at] = (uint8_t)v;
  p[at + 1] = (uint8_t)(v >> 8);
}
static void put_u32(uint8_t* p, size_t at, uint32_t v) {
  for (size_t i = 0; i < 4; ++i) p[at + i] = (uint8_t)(v >> (8 * i));
}
static void put_u64(uint8_t* p, size_t at, uint64_t v) {
  for (size_t i = 0; i < 8; ++i) p[at + i] = (uint8_t)(v >> (8 * i));
}
static uint16_t get_u16(const uint8_t* p, size_t at) { return (uint16_t)(p[at] | (p[at + 1] << 8)); }
static uint32_t get_u32(const uint8_t* p, size_t at) {
  uint32_t v = 0;
  for (size_t i = 0; i < 4; ++i) v |= (uint32_t)p[at + i] << (8 * i);
  return v;
}
static uint64_t get_u64(const uint8_t* p, size_t at) {
  uint64_t v = 0;
  for (size_t i = 0; i < 8; ++i) v |= (uint64_t)p[at + i] << (8 * i);
  return v;
}

static void put_header(uint8_t* p, uint8_t type, size_t payload, uint32_t session, uint32_t sequence) {
  put_u32(p, kMagicAt, MFB_MAGIC);
  p[kVersionAt] = (uint8_t)MFB_PROTOCOL_VERSION;
  p[kTypeAt] = type;
  put_u16(p, kLengthAt, (uint16_t)payload);
  put_u32(p, kSessionAt, session);
  put_u32(p, kSequenceAt, sequence);
}

static void put_trailer(uint8_t* p, size_t size, const uint8_t* key, mfb_mac_fn mac, void* ctx) {
  const size_t crc_at = size - MFB_TRAILER_SIZE;
  put_u32(p, crc_at, mfb_crc32c(p, crc_at));
  mac(ctx, key, p, size - MFB_MAC_SIZE, p + size - MFB_MAC_SIZE);
}

/* Constant time, so that the time to reject a forgery does not tell how many bytes were right. */
static bool equal_in_constant_time(const uint8_t* a, const uint8_t* b, size_t n) {
  uint8_t d = 0;
  for (size_t i = 0; i < n; ++i) d |= (uint8_t)(a[i] ^ b[i]);
  return d == 0;
}

mfb_parse_error mfb_decode_command(const uint8_t* in, size_t size, const uint8_t key[MFB_KEY_SIZE], mfb_mac_fn mac,
                                   void* mac_ctx, mfb_command* out) {
  if (size < MFB_HEADER_SIZE) return MFB_PARSE_TOO_SHORT;
  if (get_u32(in, kMagicAt) != MFB_MAGIC) return MFB_PARSE_BAD_MAGIC;
  if (in[kVersionAt] != MFB_PROTOCOL_VERSION) return MFB_PARSE_BAD_VERSION;
  if (in[kTypeAt] != MFB_TYPE_COMMAND && in[kTypeAt] != MFB_TYPE_HELLO) return MFB_PARSE_WRONG_TYPE;
  if (get_u16(in, kLengthAt) != MFB_COMMAND_PAYLOAD_SIZE) return MFB_PARSE_BAD_LENGTH;
  if (size < MFB_COMMAND_PACKET_SIZE) return MFB_PARSE_TOO_SHORT;
  if (size > MFB_COMMAND_PACKET_SIZE) return MFB_PARSE_TOO_LONG;
  const size_t crc_at = MFB_COMMAND_PACKET_SIZE - MFB_TRAILER_SIZE;
  if (get_u32(in, crc_at) != mfb_crc32c(in, crc_at)) return MFB_PARSE_BAD_CRC;
  uint8_t expected[MFB_MAC_SIZE];
  mac(mac_ctx, key, in, MFB_COMMAND_PACKET_SIZE - MFB_MAC_SIZE, expected);
  if (!equal_in_constant_time(expected, in + MFB_COMMAND_PACKET_SIZE - MFB_MAC_SIZE, MFB_MAC_SIZE)) return MFB_PARSE_BAD_MAC;
  mfb_command c;
  c.type = in[kTypeAt];
  c.session_id = get_u32(in, kSessionAt);
  c.sequence = get_u32(in, kSequenceAt);
  c.host_time_ns = get_u64(in, kCmdHostTimeAt);
  for (size_t i = 0; i < MFB_DA_CHANNELS; ++i) c.da[i] = get_u16(in, kCmdDaAt + 2 * i);
  c.digital_out = in[kCmdDigitalOutAt];
  c.flags = in[kCmdFlagsAt];
  c.board_nonce = get_u64(in, kCmdBoardNonceAt);
  if ((c.flags & ~MFB_COMMAND_KNOWN_FLAGS) != 0) return MFB_PARSE_BAD_FLAGS;
  if (c.type == MFB_TYPE_HELLO) { /* a hello drives nothing and names no board nonce */
    uint16_t any = (uint16_t)(c.digital_out | c.flags);
    for (size_t i = 0; i < MFB_DA_CHANNELS; ++i) any = (uint16_t)(any | c.da[i]);
    if (any != 0 || c.board_nonce != 0) return MFB_PARSE_BAD_FLAGS;
  }
  if (c.session_id == 0) return MFB_PARSE_ZERO_SESSION;
  *out = c;
  return MFB_PARSE_OK;
}

size_t mfb_encode_state(const mfb_state* s, const uint8_t key[MFB_KEY_SIZE], mfb_mac_fn mac, void* mac_ctx,
                        uint8_t* out, size_t capacity) {
  if (capacity < MFB_STATE_PACKET_SIZE) return 0;
  put_header(out, MFB_TYPE_STATE, MFB_STATE_PAYLOAD_SIZE, s->session_id, s->sequence);
  put_u64(out, kStEchoAt, s->echo_host_time_ns);
  put_u64(out, kStBoardTimeAt, s->board_time_ns);
  put_u32(out, kStAckAt, s->ack_sequence);
  for (size_t i = 0; i < MFB_AD_CHANNELS; ++i) put_u16(out, kStAdAt + 2 * i, s->ad[i]);
  for (size_t i = 0; i < MFB_ENCODER_CHANNELS; ++i) put_u32(out, kStEncoderAt + 4 * i, (uint32_t)s->encoder[i]);
  out[kStDigitalInAt] = s->digital_in;
  out[kStStatusAt] = s->status;
  put_u64(out, kStBoardNonceAt, s->board_nonce);
  put_u32(out, kStBootIdAt, s->boot_id);
  put_u16(out, kStLimitVentedAt, s->limit_vented);
  out[kStLimitMotorOffAt] = s->limit_motor_off;
  put_trailer(out, MFB_STATE_PACKET_SIZE, key, mac, mac_ctx);
  return MFB_STATE_PACKET_SIZE;
}

size_t mfb_encode_command(const mfb_command* c, const uint8_t key[MFB_KEY_SIZE], mfb_mac_fn mac, void* mac_ctx,
                          uint8_t* out, size_t capacity) {
  if (capacity < MFB_COMMAND_PACKET_SIZE) return 0;
  put_header(out, c->type, MFB_COMMAND_PAYLOAD_SIZE, c->session_id, c->sequence);
  put_u64(out, kCmdHostTimeAt, c->host_time_ns);
  for (size_t i = 0; i < MFB_DA_CHANNELS; ++i) put_u16(out, kCmdDaAt + 2 * i, c->da[i]);
  out[kCmdDigitalOutAt] = c->digital_out;
  out[kCmdFlagsAt] = c->flags;
  put_u64(out, kCmdBoardNonceAt, c->board_nonce);
  put_trailer(out, MFB_COMMAND_PACKET_SIZE, key, mac, mac_ctx);
  return MFB_COMMAND_PACKET_SIZE;
}
