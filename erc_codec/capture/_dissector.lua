-- The dissector's runtime: erc_codec/capture/_wireshark.py writes the SCHEMA table in front of it.
--
-- It decodes a datagram as erc_codec's decode does, with the same outcome on every input:
-- 1. an empty datagram, or one longer than the envelope's maximum size, is refused;
-- 2. the top-level fields are walked, bytes past the end read as the zeros a sender stripped;
--    a zero byte where a tag is expected starts padding, which must be zeros to the end;
-- 3. the exact envelope so restored is parsed as Google's protobuf runtime (upb) parses it:
--    tags of at most 5 bytes, varints of at most 10, field number 0, wire types 6 and 7, groups
--    left open or closed by another field, lengths past the end, 100 levels of nesting, bad
--    UTF-8 in a proto3 string, a packed field cut inside an element are all corrupt; a known
--    field on another wire type, an unknown field, and a map entry holding one are kept aside
--    as unknown fields;
-- 4. where zeros were restored, a restoration no encoder could have sent is a datagram cut short,
--    refused with reason "truncated" (erc_codec's _truncation): a field without presence at its
--    default as the deepest last field, or the last byte that arrived continuing a varint;
-- 5. the payload is the last envelope member on the wire; without one the datagram is refused
--    (no payload, metadata but no payload, an unknown member, a member on the wrong wire type).
--    The envelope's fields beside its members (metadata: the rover's timeout) are shown as
--    fields, never taken for the payload; a restored default in one is a cut as in any field.
-- Nothing is added to the tree before the whole datagram has parsed, so a corrupt datagram shows
-- its reason and its bytes, never a field that is not there. Numbers are exact: 64-bit varints
-- go through UInt64/Int64 (Lua 5.2's numbers are doubles), floats are labelled with the
-- shortest decimal that reads back as the same value, as erc-codec decode prints them.

local MAX_DEPTH = 100 -- upb's default nesting limit
local T = {
    DOUBLE = 1, FLOAT = 2, INT64 = 3, UINT64 = 4, INT32 = 5, FIXED64 = 6, FIXED32 = 7, BOOL = 8,
    STRING = 9, GROUP = 10, MESSAGE = 11, BYTES = 12, UINT32 = 13, ENUM = 14, SFIXED32 = 15, SFIXED64 = 16,
    SINT32 = 17, SINT64 = 18,
}
local WIRE = { [T.DOUBLE] = 1, [T.FIXED64] = 1, [T.SFIXED64] = 1, [T.FLOAT] = 5, [T.FIXED32] = 5,
    [T.SFIXED32] = 5, [T.STRING] = 2, [T.MESSAGE] = 2, [T.BYTES] = 2 } -- the rest: varints (0)
local WIRE_NAMES = { [0] = "VARINT", [1] = "I64", [2] = "LEN", [3] = "SGROUP", [4] = "EGROUP",
    [5] = "I32", [6] = "wire type 6", [7] = "wire type 7" }
local TWO32, TWO31 = 4294967296, 2147483648

local function wire_of(ftype) return WIRE[ftype] or 0 end

-- -- the protocol and its fields -------------------------------------------------------------

local erc = Proto("erc", "ERC rover PBEnvelope")
local member_names, metadata_names = {}, {} -- the members (messages), the fields beside them
for _, field in ipairs(SCHEMA.messages[SCHEMA.root].fields) do
    if field.message then member_names[field.number] = field.name
    else metadata_names[field.number] = field.name end
end
local hf = {
    kind = ProtoField.string("erc.kind", "Kind"),
    member = ProtoField.uint32("erc.member", "Member", base.DEC, member_names),
    form = ProtoField.string("erc.form", "Form"),
    length = ProtoField.uint32("erc.length", "Length"),
    restored = ProtoField.uint32("erc.restored", "Zero bytes restored"),
    padding = ProtoField.uint32("erc.padding", "Zero bytes of padding"),
    reason = ProtoField.string("erc.reason", "Reason"),
    error = ProtoField.string("erc.error", "Error"),
    data = ProtoField.bytes("erc.data", "Data"),
    unknown = ProtoField.bytes("erc.unknown", "Unknown field"),
    unknown_number = ProtoField.uint32("erc.unknown.number", "Field number"),
    unknown_wire = ProtoField.string("erc.unknown.wire_type", "Wire type"),
}
local fields = {}
for _, f in pairs(hf) do fields[#fields + 1] = f end

local function protofield(message, field)
    local abbrev = "erc." .. message.name .. "." .. field.name
    local t = field.type
    if t == T.DOUBLE then return ProtoField.double(abbrev, field.name) end
    if t == T.FLOAT then return ProtoField.float(abbrev, field.name) end
    if t == T.INT64 or t == T.SINT64 or t == T.SFIXED64 then
        return ProtoField.int64(abbrev, field.name)
    end
    if t == T.UINT64 or t == T.FIXED64 then return ProtoField.uint64(abbrev, field.name) end
    if t == T.ENUM then
        return ProtoField.int32(abbrev, field.name, base.DEC, SCHEMA.enums[field.enum])
    end
    if t == T.INT32 or t == T.SINT32 or t == T.SFIXED32 then
        return ProtoField.int32(abbrev, field.name)
    end
    if t == T.UINT32 or t == T.FIXED32 then return ProtoField.uint32(abbrev, field.name) end
    if t == T.BOOL then return ProtoField.bool(abbrev, field.name) end
    if t == T.STRING then return ProtoField.string(abbrev, field.name) end
    if t == T.BYTES then return ProtoField.bytes(abbrev, field.name) end
    return ProtoField.none(abbrev, field.name) -- a message: the subtree of its fields
end

for _, message in ipairs(SCHEMA.messages) do
    message.by_number = {}
    for _, field in ipairs(message.fields) do
        field.hf = protofield(message, field)
        fields[#fields + 1] = field.hf
        message.by_number[field.number] = field
    end
end
erc.fields = fields

local ex = {
    stripped = ProtoExpert.new("erc.stripped", "Stripped trailing zeros restored",
        expert.group.PROTOCOL, expert.severity.CHAT),
    padded = ProtoExpert.new("erc.padded", "Zero padding after the envelope",
        expert.group.PROTOCOL, expert.severity.CHAT),
    refused = ProtoExpert.new("erc.refused", "Not a PBEnvelope datagram",
        expert.group.MALFORMED, expert.severity.ERROR),
    unknown_member = ProtoExpert.new("erc.unknown_member", "Unknown envelope member",
        expert.group.UNDECODED, expert.severity.WARN),
    unknown_field = ProtoExpert.new("erc.unknown_field", "Unknown field",
        expert.group.UNDECODED, expert.severity.NOTE),
    overridden = ProtoExpert.new("erc.overridden", "Given again later on the wire",
        expert.group.PROTOCOL, expert.severity.NOTE),
}
erc.experts = { ex.stripped, ex.padded, ex.refused, ex.unknown_member, ex.unknown_field,
    ex.overridden }

-- -- numbers -----------------------------------------------------------------------------------

-- A varint at 0-based offset pos of s, before stop, of at most maxlen bytes: its low and high
-- 32 bits and the offset after it; or nil and what is wrong.
local function varint(s, pos, stop, maxlen)
    local lo, hi, shift = 0, 0, 0
    for i = 0, maxlen - 1 do
        if pos + i >= stop then return nil, "a varint at offset " .. pos .. " is cut off" end
        local b = s:byte(pos + i + 1)
        local g = b % 128
        if shift < 28 then
            lo = lo + g * 2 ^ shift
        elseif shift == 28 then
            lo = lo + (g % 16) * 2 ^ 28
            hi = hi + (g - g % 16) / 16
        elseif shift < 63 then
            hi = hi + g * 2 ^ (shift - 32)
        else
            hi = hi + (g % 2) * TWO31 -- bits past 64 are dropped, as upb drops them
        end
        if b < 128 then return lo, hi, pos + i + 1 end
        shift = shift + 7
    end
    return nil, "a varint at offset " .. pos .. " is longer than " .. maxlen .. " bytes"
end

local function le32(s, pos)
    local a, b, c, d = s:byte(pos + 1, pos + 4)
    return a + b * 256 + c * 65536 + d * 16777216
end

local function signed32(u) if u >= TWO31 then return u - TWO32 end return u end

local function frexp(x) -- math.frexp, gone from Lua 5.3 on: x = m * 2^e, 0.5 <= |m| < 1
    if math.frexp then return math.frexp(x) end
    local m, e = math.abs(x), 0
    while m >= 1 do m, e = m / 2, e + 1 end
    while m < 0.5 do m, e = m * 2, e - 1 end
    return (x < 0) and -m or m, e
end

local function to_float32(d) -- the float32 nearest to double d, ties to even
    if d ~= d or d == 0 or d == math.huge or d == -math.huge then return d end
    local m, e = frexp(math.abs(d))
    local bits = (e < -125) and (24 - (-125 - e)) or 24 -- subnormals keep fewer bits
    if bits < 0 then return (d < 0) and -0.0 or 0.0 end
    local x = m * 2 ^ bits
    local r = math.floor(x + 0.5)
    if r - x == 0.5 and r % 2 == 1 then r = r - 1 end
    local out = r * 2 ^ (e - bits)
    if out > 3.4028234663852886e38 then out = math.huge end
    return (d < 0) and -out or out
end

local function special(v)
    if v ~= v then return "NaN" end
    if v == math.huge then return "Infinity" end
    if v == -math.huge then return "-Infinity" end
end

local function shortest_double(v)
    local named = special(v)
    if named then return named end
    for p = 15, 17 do
        local text = string.format("%." .. p .. "g", v)
        if tonumber(text) == v then return text end
    end
end

local function shortest_float(v) -- as protobuf's JSON printer picks it: 6 digits and up
    local named = special(v)
    if named then return named end
    for p = 6, 9 do
        local text = string.format("%." .. p .. "g", v)
        if to_float32(tonumber(text)) == v then return text end
    end
end

local function valid_utf8(s, from, to) -- bytes from..to (1-based, inclusive); as upb checks
    local i = from
    while i <= to do
        local c = s:byte(i)
        local n, low, high = 0, 0x80, 0xBF
        if c < 0x80 then n = 0
        elseif c >= 0xC2 and c <= 0xDF then n = 1
        elseif c == 0xE0 then n, low = 2, 0xA0
        elseif c == 0xED then n, high = 2, 0x9F
        elseif c >= 0xE1 and c <= 0xEF then n = 2
        elseif c == 0xF0 then n, low = 3, 0x90
        elseif c >= 0xF1 and c <= 0xF3 then n = 3
        elseif c == 0xF4 then n, high = 3, 0x8F
        else return false end
        if i + n > to then return false end
        for k = 1, n do
            local b = s:byte(i + k)
            if b < low or b > high then return false end
            low, high = 0x80, 0xBF
        end
        i = i + n + 1
    end
    return true
end

-- -- parsing -----------------------------------------------------------------------------------

local parse_message

-- The offset after the group ``number`` whose fields start at pos (nested at ``depth``).
local function skip_group(s, pos, stop, number, depth)
    if depth > MAX_DEPTH then return nil, "groups nest deeper than " .. MAX_DEPTH end
    local _, after, err = parse_message(s, pos, stop, nil, depth, number)
    return after, err
end

-- Where the value of a field of wire type wt starting at pos ends (nil, error if it cannot).
local function skip_value(s, pos, stop, wt, number, depth)
    if wt == 0 then
        local lo, err_or_hi, after = varint(s, pos, stop, 10)
        if not lo then return nil, err_or_hi end
        return after
    elseif wt == 1 or wt == 5 then
        local after = pos + (wt == 1 and 8 or 4)
        if after > stop then return nil, "field " .. number .. "'s value is cut off" end
        return after
    elseif wt == 2 then
        local lo, hi, after = varint(s, pos, stop, 5)
        if not lo then return nil, hi end
        if hi ~= 0 or after + lo > stop then
            return nil, "field " .. number .. "'s length runs past the end"
        end
        return after + lo, nil, after
    elseif wt == 3 then
        return skip_group(s, pos, stop, number, depth + 1)
    end
    return nil, WIRE_NAMES[wt] .. " (field " .. number .. ") is not a protobuf wire type"
end

-- One scalar value of field f at pos (its wire type is the field's): value, offset after.
local function scalar(s, pos, stop, f)
    local t = f.type
    local w = wire_of(t)
    if w == 1 or w == 5 then
        local after = pos + (w == 1 and 8 or 4)
        if after > stop then return nil, "a fixed-size value is cut off" end
        return true, after -- read from the bytes when shown (add_le)
    end
    local lo, hi, after = varint(s, pos, stop, 10)
    if not lo then return nil, hi end
    local value
    if t == T.BOOL then value = (lo ~= 0 or hi ~= 0)
    elseif t == T.UINT32 then value = lo
    elseif t == T.INT32 or t == T.ENUM then value = signed32(lo)
    elseif t == T.SINT32 then
        value = (lo % 2 == 0) and lo / 2 or -(lo + 1) / 2
    elseif t == T.UINT64 then value = UInt64(lo, hi)
    elseif t == T.INT64 then value = Int64(lo, hi)
    else -- SINT64: zigzag
        local half = UInt64(lo, hi):rshift(1)
        value = (lo % 2 == 0) and Int64(half:lower(), half:higher())
            or Int64(half:lower(), half:higher()):bnot()
    end
    return value, after
end

local function declared(f, value)
    return not f.closed or SCHEMA.enums[f.enum][value] ~= nil
end

-- Parse the fields of message ``mi`` (nil: an unknown group) in s[pos, stop) at nesting level
-- ``depth``. Returns the parsed message, the offset after it (after the end-group tag of
-- ``group``, when one is given), or nil and an error.
parse_message = function(s, pos, stop, mi, depth, group)
    local spec = mi and SCHEMA.messages[mi]
    local message = { spec = spec, entries = {} }
    while pos < stop do
        local start = pos
        local lo, hi, after = varint(s, pos, stop, 5)
        if not lo then return nil, nil, "tag: " .. hi end
        if hi ~= 0 then return nil, nil, "a tag at offset " .. start .. " is over 32 bits" end
        local wt = lo % 8
        local number = (lo - wt) / 8
        if number == 0 then return nil, nil, "field number 0 at offset " .. start end
        if wt == 4 then
            if group == number then return message, after end
            return nil, nil, "an end-group tag at offset " .. start .. " closes no open group"
        end
        local f = spec and spec.by_number[number]
        local entry = { f = f, number = number, wt = wt, start = start, vstart = after }
        if f and wt == wire_of(f.type) then
            if f.type == T.MESSAGE then
                local clo, chi, content = varint(s, after, stop, 5)
                if not clo then return nil, nil, chi end
                if chi ~= 0 or content + clo > stop then
                    return nil, nil, f.name .. "'s length runs past the end"
                end
                if depth + 1 > MAX_DEPTH then
                    return nil, nil, "messages nest deeper than " .. MAX_DEPTH
                end
                local sub, _, err = parse_message(s, content, content + clo, f.message, depth + 1)
                if not sub then return nil, nil, err end
                entry.sub, entry.content, pos = sub, content, content + clo
                if SCHEMA.messages[f.message].map_entry then
                    for _, e in ipairs(sub.entries) do -- upb keeps such an entry out of the map
                        if not e.f then
                            entry.f, entry.known_number, entry.map_entry = nil, true, true
                        end
                    end
                end
            elseif wt == 2 then -- string, bytes
                local clo, chi, content = varint(s, after, stop, 5)
                if not clo then return nil, nil, chi end
                if chi ~= 0 or content + clo > stop then
                    return nil, nil, f.name .. "'s length runs past the end"
                end
                if f.utf8 and not valid_utf8(s, content + 1, content + clo) then
                    return nil, nil, f.name .. " is not valid UTF-8"
                end
                entry.content, pos = content, content + clo
            else
                local value, next_pos = scalar(s, after, stop, f)
                if value == nil then return nil, nil, next_pos end
                entry.value, pos = value, next_pos
                if f.type == T.ENUM and not declared(f, value) then
                    entry.f, entry.known_number, entry.undeclared = nil, true, value
                end
            end
        elseif f and wt == 2 and f.repeated and wire_of(f.type) ~= 2 then -- packed
            local clo, chi, content = varint(s, after, stop, 5)
            if not clo then return nil, nil, chi end
            if chi ~= 0 or content + clo > stop then
                return nil, nil, f.name .. "'s length runs past the end"
            end
            entry.elements, entry.content = {}, content
            local at = content
            while at < content + clo do
                local value, next_pos = scalar(s, at, content + clo, f)
                if value == nil then return nil, nil, "packed " .. f.name .. ": " .. next_pos end
                local known = f.type ~= T.ENUM or declared(f, value)
                entry.elements[#entry.elements + 1] =
                    { at = at, stop = next_pos, value = value, known = known }
                at = next_pos
            end
            pos = content + clo
        else
            local next_pos, err = skip_value(s, after, stop, wt, number, depth)
            if not next_pos then return nil, nil, err end
            entry.f, pos = nil, next_pos -- an unknown field (or a known one on another wire type)
            entry.known_number = f ~= nil
        end
        entry.stop = pos
        message.entries[#message.entries + 1] = entry
    end
    if group then return nil, nil, "field " .. group .. "'s group is not closed" end
    return message, pos
end

-- -- restoring the envelope (erc_codec's decode) -------------------------------------------------

-- The exact envelope of datagram s: its bytes, the form ("exact", "strip", "pad") and how many
-- zeros were restored or cut; or nil and an error.
local function restore(s, n)
    local pos = 0
    while pos < n do
        if s:byte(pos + 1) == 0 then
            for i = pos + 1, n - 1 do
                if s:byte(i + 1) ~= 0 then
                    return nil, "a zero byte at offset " .. pos .. " ends the message, but a " ..
                        "non-zero byte follows at offset " .. i
                end
            end
            return s:sub(1, pos), "pad", n - pos
        end
        local lo, hi, after = varint(s, pos, n, 10)
        if not lo then return nil, hi end
        local wt = lo % 8
        local number = (lo - wt) / 8 + hi * (TWO32 / 8)
        if number == 0 then return nil, "field number 0 at offset " .. pos end
        if wt == 2 then
            if after >= n then
                pos = after + 1 -- the length was a stripped zero
            else
                local llo, lhi, content = varint(s, after, n, 10)
                if not llo then return nil, lhi end
                pos = content + llo + lhi * TWO32
            end
        elseif wt == 0 then
            if after >= n then
                pos = after + 1
            else
                local vlo, vhi, next_pos = varint(s, after, n, 10)
                if not vlo then return nil, vhi end
                pos = next_pos
            end
        elseif wt == 1 or wt == 5 then
            pos = after + (wt == 1 and 8 or 4)
        elseif wt == 3 or wt == 4 then
            return nil, "field " .. number .. " is a group (wire type " .. wt .. "), which a " ..
                "proto3 envelope never holds"
        else
            return nil, "wire type " .. wt .. " at offset " .. pos .. " is not protobuf's"
        end
    end
    if pos > SCHEMA.max_size then
        return nil, "restoring its stripped zeros makes the datagram " .. pos ..
            " bytes long, more than the envelope's maximum of " .. SCHEMA.max_size
    end
    if pos == n then return s, "exact", 0 end
    return s .. string.rep("\0", pos - n), "strip", pos - n
end

-- erc_codec's fast path (Envelope.peek): a datagram of one member with a short tag and length
-- has its payload parsed on its own, so the payload may nest one level deeper.
local function payload_alone(s, n)
    if n == 0 or n > SCHEMA.max_size then return false end
    local first = s:byte(1)
    local number
    if first < 128 then
        number = (first % 8 == 2) and (first - 2) / 8 or nil
    elseif n > 1 and s:byte(2) < 128 and first % 8 == 2 and s:byte(2) > 0 then
        number = ((first - 128) - 2) / 8 + s:byte(2) * 16
    end
    if not number or not member_names[number] then return false end
    local start = (first < 128) and 1 or 2
    if start == n then return true end
    local length = s:byte(start + 1)
    if length < 128 then start = start + 1
    elseif start + 1 < n and s:byte(start + 2) < 128 then
        length = length - 128 + s:byte(start + 2) * 128
        start = start + 2
    else return false end
    local stop = start + length
    if stop == n then return true end
    if stop < n then
        for i = stop + 1, n do if s:byte(i) ~= 0 then return false end end
        return true
    end
    return stop <= SCHEMA.max_size
end

-- -- cut, not stripped (erc_codec's _truncation) --------------------------------------------------

-- A stripped datagram lost zeros that all belong to the last field at every level of nesting.
-- Restoring them is wrong where no encoder could have written the result: a field without
-- presence at its default (proto3 encoders leave those out), or a varint ending in a restored zero
-- after a continuation byte (encoders write varints in their shortest form). Both walks go over
-- the parsed, restored envelope and judge only fields the schema declares, on a wire type they may
-- arrive in (a repeated scalar packed or not), as erc_codec's presence_table lists them.
local SENT, ZERO_VARINT, ZERO_FIXED, EMPTY, NESTED = 1, 2, 3, 4, 5
local WIDE = { [T.INT64] = true, [T.UINT64] = true, [T.SINT64] = true, [T.BOOL] = true }

-- What the walks ask of field ``number`` of message ``spec`` arriving on wire type wt, and the
-- field; nil for what the schema does not declare so (it travels as it came).
local function asked(spec, number, wt)
    local f = spec.by_number[number]
    if not f or f.type == T.GROUP then return nil end -- a group: explicitly present, no varint
    local w = wire_of(f.type)
    if f.type == T.MESSAGE then
        if wt == 2 then return NESTED, f end
    elseif f.repeated then
        if wt == w then return SENT, f end -- an item: its zero is sent
        if wt == 2 then return EMPTY, f end -- packed: never an empty list
    elseif wt == w then
        if f.presence or spec.map_entry then return SENT, f end -- their zeros are sent
        if w == 0 then return ZERO_VARINT, f end
        if w == 2 then return EMPTY, f end
        return ZERO_FIXED, f
    end
    return nil
end

-- The chain of last fields from message m (of spec) down to the deepest one, if that one holds a
-- default no encoder writes (a 32-bit field keeps the low 32 bits of its varint); else nil.
local function cut_field(s, m, spec)
    local chain = {}
    while true do
        local last = m.entries[#m.entries]
        if not last then return nil end
        local ask, f = asked(spec, last.number, last.wt)
        if not ask or ask == SENT then return nil end
        chain[#chain + 1] = { f = f, entry = last }
        if ask == NESTED then
            if last.content == last.stop then return nil end -- a present empty submessage
            m, spec = last.sub, SCHEMA.messages[f.message]
        elseif ask == ZERO_VARINT then
            local lo, hi = varint(s, last.vstart, last.stop, 10)
            return (lo == 0 and (hi == 0 or not WIDE[f.type])) and chain or nil
        elseif ask == ZERO_FIXED then
            for i = last.vstart + 1, last.stop do
                if s:byte(i) ~= 0 then return nil end
            end
            return chain
        else
            return (last.content == last.stop) and chain or nil
        end
    end
end

-- The chain of fields from message m (of spec) down to the one whose varint (a tag, a length, a
-- varint value, an item of a packed varint list) holds byte ``last``; nil if no declared field's.
local function varint_cut(m, spec, last)
    local chain = {}
    while true do
        local found
        for _, entry in ipairs(m.entries) do
            if last < entry.stop then found = entry; break end
        end
        if not found then return nil end
        local ask, f = asked(spec, found.number, found.wt)
        if not ask then return nil end
        chain[#chain + 1] = { f = f, entry = found }
        if last < (found.content or found.vstart) or found.wt == 0 then return chain end
        if ask ~= NESTED then -- fixed-width, text, bytes, or a packed list: of varints, or not
            return (ask == EMPTY and f.repeated and wire_of(f.type) == 0) and chain or nil
        end
        m, spec = found.sub, SCHEMA.messages[f.message]
    end
end

-- The parsed occurrences of message field f in the messages ``occurrences`` that protobuf merges
-- into one: all of them, those before a later member of f's oneof cleared.
local function merged(occurrences, f)
    local out = {}
    for _, m in ipairs(occurrences) do
        for _, e in ipairs(m.entries) do
            if e.f == f then out[#out + 1] = e.sub
            elseif f.oneof and e.f and e.f.oneof == f.oneof then out = {} end
        end
    end
    return out
end

-- A map entry's key (s: the bytes its parse ``entry`` points into), as the JSON mapping writes it.
local function key_text(s, entry, spec)
    local key = spec.by_number[1]
    local found
    for _, e in ipairs(entry.entries) do
        if e.f == key then found = e end
    end
    local t = key.type
    if not found then return (t == T.BOOL and "false") or (t == T.STRING and "") or "0" end
    if t == T.STRING then return s:sub(found.content + 1, found.stop) end
    if t == T.BOOL then return found.value and "true" or "false" end
    local at = found.vstart
    if t == T.FIXED32 then return string.format("%d", le32(s, at)) end
    if t == T.SFIXED32 then return string.format("%d", signed32(le32(s, at))) end
    if t == T.FIXED64 then return tostring(UInt64(le32(s, at), le32(s, at + 4))) end
    if t == T.SFIXED64 then return tostring(Int64(le32(s, at), le32(s, at + 4))) end
    if type(found.value) == "number" then return string.format("%d", found.value) end
    return tostring(found.value)
end

-- The full path of a chain's last field from the payload type, as decode names it: items by index
-- in the message protobuf builds (the last item, as the chain follows last fields), map entries
-- by key (LimitsRecord.places[key=7].x).
local function cut_path(s, envelope, chain)
    local member = chain[1].f
    if not member.message then -- a metadata field: named from the envelope
        return SCHEMA.messages[SCHEMA.root].name .. "." .. member.name
    end
    local path = SCHEMA.messages[member.message].name
    local current = merged({ envelope }, member)
    local i = 2
    while i <= #chain do
        local f, entry = chain[i].f, chain[i].entry
        local sub = f.type == T.MESSAGE and SCHEMA.messages[f.message]
        if sub and sub.map_entry then
            path = path .. "." .. f.name .. "[key=" .. key_text(s, entry.sub, sub) .. "]"
            current = merged({ entry.sub }, sub.by_number[2])
            i = i + 1 -- the entry's key or value field: the walk goes on inside it
        elseif sub and f.repeated then
            local items = 0
            for _, m in ipairs(current) do
                for _, e in ipairs(m.entries) do
                    if e.f == f then items = items + 1 end
                end
            end
            path = path .. "." .. f.name .. "[" .. (items - 1) .. "]"
            current = { entry.sub }
        else
            path = path .. "." .. f.name
            if sub then current = merged(current, f) end
        end
        i = i + 1
    end
    return path
end

local function default_text(f)
    if f.type == T.ENUM then return SCHEMA.enums[f.enum][0] or "0" end
    if f.type == T.STRING or f.type == T.BYTES then return '""' end
    if f.type == T.BOOL then return "false" end
    if f.type == T.FLOAT or f.type == T.DOUBLE then return "0.0" end
    return "0"
end

-- Why restoring the zeros after the first n bytes of s (the restored envelope, parsed to
-- ``envelope``) made what no encoder sends, in decode's words; nil for a stripped datagram.
local function cut_reason(s, envelope, n)
    local root = SCHEMA.messages[SCHEMA.root]
    local last = s:byte(n) -- the last byte that arrived
    if last >= 128 then
        local chain = varint_cut(envelope, root, n - 1)
        if chain then
            local named = #chain > 1 or not chain[1].f.message -- not a member's tag or length
            local where = named and ("in " .. cut_path(s, envelope, chain) .. " ") or ""
            return "its last byte " .. where .. "continues a varint that only a restored zero " ..
                "would end (" .. string.format("0x%02x", last) .. " 0x00, which no encoder writes)"
        end
    end
    local chain = cut_field(s, envelope, root)
    if not chain then return nil end
    local f = chain[#chain].f
    local value = f.repeated and "[] (an empty packed list)" or default_text(f)
    return "restoring its stripped zeros would make " .. cut_path(s, envelope, chain) .. " = " ..
        value .. ", a default no proto3 encoder sends for a field without presence"
end

-- -- showing -----------------------------------------------------------------------------------

local show_message

local function label_of(f, value, range)
    local t = f.type
    if t == T.DOUBLE then return shortest_double(range:le_float()) end
    if t == T.FLOAT then return shortest_float(range:le_float()) end
    if t == T.FIXED32 then return tostring(range:le_uint()) end
    if t == T.SFIXED32 then return tostring(range:le_int()) end
    if t == T.FIXED64 then return tostring(range:le_uint64()) end
    if t == T.SFIXED64 then return tostring(range:le_int64()) end
    if t == T.BOOL then return value and "true" or "false" end
    if t == T.ENUM then
        local name = SCHEMA.enums[f.enum][value]
        local number = string.format("%d", value)
        return name and (name .. " (" .. number .. ")") or ("undeclared (" .. number .. ")")
    end
    if type(value) == "number" then return string.format("%d", value) end
    return tostring(value)
end

local function add_value(tree, f, range, value)
    local w = wire_of(f.type)
    local item
    if w == 1 or w == 5 then item = tree:add_le(f.hf, range)
    else item = tree:add(f.hf, range, value) end
    item:set_text(f.name .. ": " .. label_of(f, value, range))
    return item
end

local function add_unknown(tree, tvb, entry, why)
    local item = tree:add(hf.unknown, tvb(entry.start, entry.stop - entry.start))
    item:set_text("Unknown field " .. entry.number .. " (" .. WIRE_NAMES[entry.wt] .. ")")
    item:add(hf.unknown_number, tvb(entry.start, entry.vstart - entry.start), entry.number)
    item:add(hf.unknown_wire, tvb(entry.start, entry.vstart - entry.start), WIRE_NAMES[entry.wt])
    item:add_proto_expert_info(ex.unknown_field, why)
end

local function show_entry(tree, tvb, s, entry, later)
    local f = entry.f
    local item
    if entry.sub then
        item = tree:add(f.hf, tvb(entry.start, entry.stop - entry.start))
        item:set_text(f.name .. " (" .. SCHEMA.messages[f.message].name .. ")")
        show_message(item, tvb, s, entry.sub)
    elseif entry.elements then
        for _, element in ipairs(entry.elements) do
            local range = tvb(element.at, element.stop - element.at)
            if element.known then
                add_value(tree, f, range, element.value)
            else
                local unknown = tree:add(hf.unknown, range)
                unknown:set_text(f.name .. ": " .. string.format("%d", element.value) ..
                    " (not a value of its closed enum)")
                unknown:add_proto_expert_info(ex.unknown_field,
                    "Not a declared value of a closed enum: protobuf keeps it as an unknown field")
            end
        end
        return
    elseif entry.content then
        local length = entry.stop - entry.content
        local range = tvb(entry.content, length)
        if f.type == T.STRING then
            item = tree:add(f.hf, range, s:sub(entry.content + 1, entry.stop))
            item:set_text(f.name .. ": " .. s:sub(entry.content + 1, entry.stop))
        else
            item = tree:add(f.hf, range)
            item:set_text(f.name .. ": " .. tostring(range:bytes()))
        end
    else
        item = add_value(tree, f, tvb(entry.vstart, entry.stop - entry.vstart), entry.value)
    end
    if later then
        local merge = f.type == T.MESSAGE and "merges it with the later one" or "keeps the later one"
        item:add_proto_expert_info(ex.overridden, "Given again later on the wire: protobuf " .. merge)
    end
end

local DEFAULTS = { [T.BOOL] = "false", [T.STRING] = "", [T.BYTES] = "" }

show_message = function(tree, tvb, s, message)
    local spec = message.spec
    local by_field, last_of_oneof = {}, {}
    for index, entry in ipairs(message.entries) do
        if entry.f then
            by_field[entry.f] = by_field[entry.f] or {}
            table.insert(by_field[entry.f], index)
            if entry.f.oneof then last_of_oneof[entry.f.oneof] = index end
        end
    end
    for _, f in ipairs(spec.fields) do
        local indexes = by_field[f]
        if indexes then
            for k, index in ipairs(indexes) do
                local later = not f.repeated and (k < #indexes or
                    (f.oneof and last_of_oneof[f.oneof] ~= index))
                show_entry(tree, tvb, s, message.entries[index], later)
            end
        elseif not f.presence and not f.repeated then -- not on the wire: its default, generated
            local item
            if f.type == T.ENUM then
                item = tree:add(f.hf, 0)
                item:set_text(f.name .. ": " .. label_of(f, 0))
            elseif f.type == T.INT64 or f.type == T.SINT64 or f.type == T.SFIXED64 then
                item = tree:add(f.hf, Int64(0))
                item:set_text(f.name .. ": 0")
            elseif f.type == T.UINT64 or f.type == T.FIXED64 then
                item = tree:add(f.hf, UInt64(0))
                item:set_text(f.name .. ": 0")
            elseif f.type == T.BOOL then
                item = tree:add(f.hf, false)
                item:set_text(f.name .. ": false")
            elseif f.type == T.STRING then
                item = tree:add(f.hf, "")
                item:set_text(f.name .. ": ")
            elseif f.type == T.BYTES then
                item = tree:add(f.hf, tvb(0, 0))
                item:set_text(f.name .. ": ")
            else
                item = tree:add(f.hf, 0)
                item:set_text(f.name .. ": " .. (DEFAULTS[f.type] or "0"))
            end
            item:set_generated()
        end
    end
    for _, entry in ipairs(message.entries) do
        if not entry.f then
            local why
            if entry.map_entry then
                why = "Field " .. entry.number .. " is a map entry holding a field it does not " ..
                    "know: protobuf keeps the whole entry as an unknown field"
            elseif entry.undeclared then
                why = "Field " .. entry.number .. " holds " .. string.format("%d", entry.undeclared)
                    .. ", not a value of its closed enum: protobuf keeps it as an unknown field"
            elseif entry.known_number then
                why = "Field " .. entry.number .. " arrived on another wire type than its own: " ..
                    "protobuf keeps it as an unknown field"
            else
                why = "Field " .. entry.number .. " is not in " .. spec.name ..
                    " in this schema (sent by a newer one?)"
            end
            add_unknown(tree, tvb, entry, why)
        end
    end
end

-- -- the dissector -----------------------------------------------------------------------------

local function refuse(tree, tvb, pinfo, reason, text)
    tree:add(hf.reason, reason)
    tree:add(hf.error, text)
    if tvb:len() > 0 then tree:add(hf.data, tvb()) end
    tree:add_proto_expert_info(ex.refused, text)
    tree:append_text(": " .. reason)
    pinfo.cols.info = "ERC " .. reason .. ": " .. text
end

-- Why a restored envelope without a member is refused, as erc_codec says it.
local function no_payload(s)
    if #s == 0 then return "no_payload", "datagram holds no payload (only zero bytes)" end
    local lo, hi = varint(s, 0, #s, 10)
    local wt = lo % 8
    local number = (lo - wt) / 8 + hi * (TWO32 / 8)
    if metadata_names[number] then -- on any wire type, as decode says it
        return "no_payload", "datagram holds metadata (" .. metadata_names[number] ..
            ") but no payload"
    end
    if member_names[number] then
        return "corrupt", "payload number " .. number .. " (" .. member_names[number] ..
            ") arrived with wire type " .. wt .. ", not 2 (length-delimited)"
    end
    return "unknown_member", "payload number " .. number .. " is not a member of " ..
        SCHEMA.messages[SCHEMA.root].name .. " in this schema (sent by a newer schema?)"
end

function erc.dissector(tvb, pinfo, tree)
    local n = tvb:len()
    pinfo.cols.protocol = "ERC"
    local top = tree:add(erc, tvb())
    top:add(hf.length, n)
    if n == 0 then return refuse(top, tvb, pinfo, "empty", "empty datagram") end
    if n > SCHEMA.max_size then
        return refuse(top, tvb, pinfo, "too_long", "a datagram of " .. n .. " bytes is longer " ..
            "than the envelope's maximum of " .. SCHEMA.max_size)
    end
    local s = tvb:raw()
    local exact, form, zeros = restore(s, n)
    if not exact then return refuse(top, tvb, pinfo, "corrupt", form) end
    local depth = payload_alone(s, n) and -1 or 0
    local envelope, _, err = parse_message(exact, 0, #exact, SCHEMA.root, depth)
    if not envelope then
        return refuse(top, tvb, pinfo, "corrupt", "not a valid " ..
            SCHEMA.messages[SCHEMA.root].name .. ": " .. err)
    end
    if form == "strip" then
        local why = cut_reason(exact, envelope, n)
        if why then
            return refuse(top, tvb, pinfo, "truncated",
                "datagram of " .. n .. " bytes was cut short: " .. why)
        end
    end
    local chosen, last_of = nil, {}
    for index, entry in ipairs(envelope.entries) do
        if entry.f then last_of[entry.f] = index end
        if entry.f and entry.f.message then chosen = entry end
    end
    if not chosen then return refuse(top, tvb, pinfo, no_payload(exact)) end
    local shown = tvb
    if form == "strip" then
        local bytes = tvb:bytes()
        bytes:set_size(#exact)
        shown = bytes:tvb("Restored envelope")
    end
    local kind = chosen.f.name
    top:append_text(", " .. kind .. " (" .. SCHEMA.messages[chosen.f.message].name .. ")")
    top:add(hf.kind, shown(chosen.start, chosen.vstart - chosen.start), kind)
    top:add(hf.member, shown(chosen.start, chosen.vstart - chosen.start), chosen.f.number)
    top:add(hf.form, form)
    if form == "strip" then
        top:add(hf.restored, zeros)
        top:add_proto_expert_info(ex.stripped, zeros .. " stripped trailing zero byte(s) restored")
    elseif form == "pad" then
        top:add(hf.padding, tvb(#exact, zeros), zeros)
        top:add_proto_expert_info(ex.padded, zeros .. " zero byte(s) of padding")
    end
    for index, entry in ipairs(envelope.entries) do
        if entry.f then -- a member given before the payload, or metadata given again later
            local later = entry.f.message and entry ~= chosen or last_of[entry.f] ~= index
            show_entry(top, shown, exact, entry, later)
        elseif metadata_names[entry.number] then
            add_unknown(top, shown, entry, "Field " .. entry.number .. " (" ..
                metadata_names[entry.number] .. ") arrived on another wire type than its own: " ..
                "protobuf keeps it as an unknown field")
        elseif entry.known_number or not member_names[entry.number] then
            local item = top:add(hf.unknown, shown(entry.start, entry.stop - entry.start))
            item:set_text("Unknown member " .. entry.number .. " (" .. WIRE_NAMES[entry.wt] .. ")")
            item:add_proto_expert_info(ex.unknown_member, entry.known_number
                and "A member on another wire type than LEN: protobuf ignores it"
                or "Member " .. entry.number .. " is not in this schema (sent by a newer one?)")
        end
    end
    pinfo.cols.info = "ERC " .. kind .. " (" .. form .. ", " .. n .. " bytes)"
    return n
end

for _, port in ipairs(SCHEMA.ports) do
    DissectorTable.get("udp.port"):add(port, erc)
end
