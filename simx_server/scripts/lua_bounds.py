"""Time bounds of Lua scripts inside C: the ``string`` and ``table`` functions whose work lies out
of the count hook's reach (:mod:`simx_server.scripts.lua`).

Lua's count hook runs between VM instructions; a library function written in C is one
instruction however long it runs, so a pattern that backtracks, ``string.rep("", 2^60)``,
``table.move`` of 2^62 slots or ``table.sort`` of ten million numbers ran for seconds to forever
with the simulation thread held, and a loop of C calls that each take 50 ms ran 10,000 of them
between two checks of the deadline. :data:`BOUNDS_LUA` wraps those functions in each script's
state (the string methods too: the strings' metatable indexes the same ``string`` table):

* **patterns** (``string.find``/``match``/``gmatch``/``gsub``): the matcher's worst case is
  estimated from the pattern before it runs, as Lua's ``lstrlib.c`` ``do_match`` backtracks: from
  the last item to the first, a single item adds 1 step, ``?`` doubles the rest (``max_expand``
  tries with and without the character), ``*``/``+``/``-`` multiply it by n + 1 (``max_expand``/
  ``min_expand``), ``%b`` and back-references add n; times n + 1 starting points unless anchored
  (``^``; not in ``gmatch``). A pattern without special characters, or ``plain``, is a byte
  search (``lmemfind``), counted n + n·m/64. Above :data:`~simx_server.base.limits.MAX_PATTERN_WORK`
  steps the call is refused with a Lua error naming the bound (``string.find(("a"):rep(34),
  ("a?"):rep(34) .. ("a"):rep(34))``: 2^34 · 35 · 35 steps, refused).
* **long C loops run in pieces**: ``string.rep`` (pieces of :data:`PIECE` repetitions; an empty
  result at once, whatever the count), ``table.concat`` and ``table.move`` (pieces of
  :data:`PIECE` elements, in the direction C would move them), ``table.sort`` of more than
  :data:`SORT_IN_C` elements without a comparator (with Lua's ``<`` as comparator: the same order
  and errors, and the hook runs in it). The results are those of the C functions.
* **every call is charged** its work (bytes, elements, matching steps, about a nanosecond
  each); every :data:`CHECK_WORK` of it the wrapper asks the script's deadline, as the hook does,
  so that a loop of expensive calls is interrupted like a loop of instructions.

The string concatenation operator ``..`` is a VM instruction, not a call: its copies are bounded
by the state's memory (:data:`~simx_server.base.limits.MAX_SCRIPT_MEMORY`); :mod:`simx_server.scripts.lua`
checks the deadline after each garbage-collection cycle too, whose pace follows the bytes copied.
"""

from __future__ import annotations

__all__ = ["BOUNDS_LUA", "CHECK_WORK", "PIECE", "SORT_IN_C"]

#: Work (about 1 ns each) charged between two checks of the deadline by the wrapped functions.
CHECK_WORK = 10 ** 7
#: Repetitions or elements of one piece of ``string.rep``, ``table.concat``, ``table.move``.
PIECE = 1 << 20
#: Most elements ``table.sort`` sorts in C without a comparator (a few ms); more are sorted with
#: Lua's ``<`` as the comparator, where the count hook reaches.
SORT_IN_C = 1 << 19

#: Called with (MAX_PATTERN_WORK, CHECK_WORK, PIECE, SORT_IN_C, MAX_SCRIPT_MEMORY); returns
#: ``install(expired, interrupt)``, which wraps the functions of the state it runs in:
#: ``expired()`` is true past the call's deadline, ``interrupt(level)`` raises the time bound's
#: error at ``level`` (and keeps raising it).
BOUNDS_LUA = r"""
local PATTERN_WORK, CHECK, PIECE, SORT_IN_C, MAX_MEMORY = ...
return function(expired, interrupt)
  local type, tostring, error, rawequal, select, ipairs = type, tostring, error, rawequal, select, ipairs
  local to_number, to_integer = tonumber, math.tointeger
  local function tonumber(x) if x == nil then return nil end return to_number(x) end
  local min, floor, huge, log = math.min, math.floor, math.huge, math.log
  local S, T = string, table
  local find, match, gmatch, gsub, rep, byte, fmt = S.find, S.match, S.gmatch, S.gsub, S.rep, S.byte, S.format
  local concat, move, sort, insert, remove = T.concat, T.move, T.sort, T.insert, T.remove

  local spent = 0
  -- Charge `work` to the running call; every CHECK of it, ask the deadline (level: the script's line).
  local function charge(work)
    if not (work > 0) then return end  -- a negative or NaN estimate (wrapped integers) must not earn credit
    spent = spent + work
    if spent > CHECK then
      spent = 0
      if expired() then interrupt(4) end
    end
  end
  local function size(s)  -- bytes of a string argument (numbers are coerced by the C functions)
    local t = type(s)
    if t == "string" then return #s elseif t == "number" then return #tostring(s) end
    return 0
  end

  -- Worst-case steps of lstrlib's do_match for pattern p on n bytes (see the module's docstring).
  local function class_end(p, i, len)  -- i at '[': the index after its ']'
    i = i + 1
    if byte(p, i) == 94 then i = i + 1 end
    repeat
      if i > len then return len + 1 end
      local c = byte(p, i)
      i = i + 1
      if c == 37 then i = i + 1 end
    until byte(p, i) == 93
    return i + 1
  end
  local function pattern_work(n, p, plain, anchors)
    local len = #p
    n = n + 0.0  -- floats: integer products would wrap around
    if plain or not find(p, "[%^%$%*%+%?%.%(%[%%%-]") then return n + n * len / 64 end
    local i, anchored = 1, anchors and byte(p, 1) == 94
    if anchored then i = 2 end
    local kinds = {}
    while i <= len do
      local c, kind, j = byte(p, i), 1, i + 1
      if c == 40 or c == 41 or (c == 36 and i == len) then kind = 0          -- ( ) and a final $
      elseif c == 37 then
        local d = byte(p, i + 1)
        if d == 98 then kind, j = 3, i + 4                                    -- %bxy: a scan
        elseif d == 102 then kind, j = 0, class_end(p, i + 2, len)            -- %f[set]
        elseif d and d >= 48 and d <= 57 then kind = 3 j = i + 2              -- %1: a comparison
        else j = i + 2 end
      elseif c == 91 then j = class_end(p, i, len) end
      if kind == 1 then
        local q = byte(p, j)
        if q == 42 or q == 43 or q == 45 then kind, j = 2, j + 1
        elseif q == 63 then kind, j = 4, j + 1 end
      end
      kinds[#kinds + 1] = kind
      i = j
    end
    local c = 1
    for k = #kinds, 1, -1 do
      local kind = kinds[k]
      if kind == 1 then c = c + 1
      elseif kind == 2 then c = (n + 1) * (c + 1)
      elseif kind == 3 then c = c + n + 1
      elseif kind == 4 then c = 2 * c + 1 end
      if c > 1e300 then return huge end
    end
    return (anchored and 1 or n + 1) * c
  end
  local function check_pattern(fname, s, p, plain, anchors)
    if type(s) ~= "string" or type(p) ~= "string" then return end  -- numbers: a few bytes
    local work = pattern_work(#s, p, plain, anchors)
    if work > PATTERN_WORK then
      error(fmt("string.%s: a pattern of %d bytes on %d bytes is refused: its matching may take %.3g steps, "
        .. "more than limits.MAX_PATTERN_WORK (%g), and C code runs out of reach of the script's time bound",
        fname, #p, #s, work, PATTERN_WORK), 3)
    end
    charge(work)
  end
  S.find = function(s, p, init, plain) check_pattern("find", s, p, plain, true) return find(s, p, init, plain) end
  S.match = function(s, p, init) check_pattern("match", s, p, false, true) return match(s, p, init) end
  S.gmatch = function(s, p, init) check_pattern("gmatch", s, p, false, false) return gmatch(s, p, init) end
  S.gsub = function(s, p, r, n)
    check_pattern("gsub", s, p, false, true)
    charge(size(s) / 8)
    return gsub(s, p, r, n)
  end

  -- string.rep: an empty result at once; long ones in pieces of PIECE repetitions.
  S.rep = function(s, n, sep)
    local k, ls, lsep = tonumber(n), size(s), size(sep)
    k = k and to_integer(k)
    if type(k) ~= "number" or k <= PIECE or (type(s) ~= "string" and type(s) ~= "number") then
      charge(2 * (k or 0) + (k or 0) * (ls + lsep) / 8)
      return rep(s, n, sep)
    end
    if ls + lsep == 0 then return "" end
    if k * 1.0 * (ls + lsep) > MAX_MEMORY then return rep(s, k, sep) end  -- fails at its first allocation
    sep = sep or ""
    local piece = rep(s, PIECE, sep)
    local whole, tail = k // PIECE, k % PIECE
    charge(2 * PIECE + k * (ls + lsep) / 8)
    local out = rep(piece, whole, sep)
    if tail > 0 then out = out .. sep .. rep(s, tail, sep) end
    return out
  end
  for _, name in ipairs({"upper", "lower", "reverse", "sub", "byte", "format", "pack", "unpack"}) do
    local f = S[name]
    S[name] = function(s, ...) charge(size(s) / 4) return f(s, ...) end
  end
  for _, name in ipairs({"len", "codepoint", "offset"}) do
    local f = utf8[name]
    utf8[name] = function(s, ...) charge(size(s) / 4) return f(s, ...) end
  end

  -- table.concat and table.move in pieces; table.sort of many elements with a Lua comparator.
  T.concat = function(t, sep, i, j)
    if type(t) ~= "table" then return concat(t, sep, i, j) end
    local a, b = tonumber(i or 1), tonumber(j or #t)
    if type(a) ~= "number" or type(b) ~= "number" or (b + 0.0) - a < PIECE then
      if type(a) == "number" and type(b) == "number" then charge(20 * ((b + 0.0) - a + 1)) end
      return concat(t, sep, i, j)
    end
    local parts = {}
    for k = a, b, PIECE do
      charge(20 * PIECE)
      parts[#parts + 1] = concat(t, sep, k, min(k + PIECE - 1, b))
    end
    return concat(parts, sep)
  end
  T.move = function(a1, f, e, t, a2)
    local nf, ne, nt = tonumber(f), tonumber(e), tonumber(t)
    nf, ne, nt = nf and to_integer(nf), ne and to_integer(ne), nt and to_integer(nt)
    -- C's own argument checks first (ltablib's tmove): what they refuse goes to C, which refuses it
    if type(nf) ~= "number" or type(ne) ~= "number" or type(nt) ~= "number" or (ne + 0.0) - nf < PIECE
       or type(a1) ~= "table" or (a2 ~= nil and type(a2) ~= "table")
       or not (nf > 0 or ne < math.maxinteger + nf) or nt > math.maxinteger - (ne - nf) then
      if type(nf) == "number" and type(ne) == "number" then charge(10 * ((ne + 0.0) - nf + 1)) end
      return move(a1, f, e, t, a2)
    end
    local count = ne - nf + 1
    -- C moves backwards when the ranges overlap forwards in one table (ltablib's tmove)
    local backwards = nt > nf and nt <= ne and (a2 == nil or rawequal(a2, a1))
    local first, last, by = 0, (count - 1) // PIECE, 1
    if backwards then first, last, by = last, 0, -1 end
    for p = first, last, by do
      local k = p * PIECE
      charge(10 * PIECE)
      move(a1, nf + k, nf + min(k + PIECE, count) - 1, nt + k, a2)
    end
    return a2 or a1
  end
  local function less(x, y) return x < y end
  T.sort = function(t, comp)
    if comp == nil and type(t) == "table" then
      local n = #t
      if n > SORT_IN_C then return sort(t, less) end
      if n > 1 then charge(15 * n * log(n, 2)) end
    end
    return sort(t, comp)
  end
  T.insert = function(t, ...)
    if type(t) == "table" and select("#", ...) == 2 then
      local pos = tonumber((...))
      if type(pos) == "number" then charge(4 * (#t - pos + 0.0)) end
    end
    return insert(t, ...)
  end
  T.remove = function(t, ...)
    if type(t) == "table" and select("#", ...) > 0 then
      local pos = tonumber((...))
      if type(pos) == "number" then charge(4 * (#t - pos + 0.0)) end
    end
    return remove(t, ...)
  end
end
"""
